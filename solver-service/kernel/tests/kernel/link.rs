//! One link, three ways.

use crate::support::Rng;
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use tractrix::ground_truth::{GroundTruthOptions, follow_path};
use tractrix::link::{
    PaperFormDegenerate, follow_the_leader_step, tractrix_paper_step, tractrix_paper_step3,
    tractrix_step,
};

fn arb_dir() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_filter("non-degenerate", |(x, y, z)| x * x + y * y + z * z > 1e-4)
        .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// Closed form = paper form (relative 1e-12) wherever the paper form is defined, over link lengths
    /// from 1e-6 to 1e6 and moves from 1e-6 to 1e3 link lengths. The paper's step 6 recovers
    /// `a = sech⁻¹(y/L)`, which is ill-conditioned when the tail is nearly perpendicular to the move
    /// (`y/L → 1`, `a → 0`: `1 − (y/L)²` cancels), with an error of about `ε / (2|c|)` link lengths
    /// (`c` = the tail's component along the move over `L`); the tolerance adds exactly that term (see
    /// `paper_form_loses_digits_near_perpendicular`, which shows the closed form is the accurate one).
    #[test]
    fn closed_form_equals_paper_form(
        td in arb_dir(), sd in arb_dir(), log_len in -6.0f64..6.0, log_b in -6.0f64..3.0,
    ) {
        let len = 10f64.powf(log_len);
        let t = td * len;
        let s = sd * (len * 10f64.powf(log_b));
        let c = tractrix_step(&t, &s, len);
        if let Ok(p) = tractrix_paper_step3(&t, &s, len) {
            let along = (t.dot(&s) / (len * s.norm())).abs();
            let scale = len * (1.0 + 4.0 * f64::EPSILON / along / 1e-12);
            prop_assert!((c.link - p.link).norm() <= 1e-12 * scale,
                "link: closed {:?} paper {:?}", c.link, p.link);
            prop_assert!((c.tail_shift - p.tail_shift).norm() <= 1e-12 * (scale + s.norm()),
                "shift: closed {:?} paper {:?}", c.tail_shift, p.tail_shift);
        }
        // The closed form keeps the length and its shift is consistent with the new link.
        prop_assert!((c.link.norm() - len).abs() <= 4.0 * f64::EPSILON * len);
        prop_assert!(((s + c.link - t) - c.tail_shift).norm() <= 1e-12 * (len + s.norm()));
    }

    /// The tail never moves farther than the head (eq. 7 integrated: dr ≤ dp).
    #[test]
    fn tail_moves_no_more_than_head(td in arb_dir(), sd in arb_dir(), log_b in -12.0f64..9.0) {
        let s = sd * 10f64.powf(log_b);
        for step in [tractrix_step(&td, &s, 1.0), follow_the_leader_step(&td, &s, 1.0)] {
            prop_assert!(step.tail_shift.norm() <= s.norm() * (1.0 + 1e-12));
        }
    }
}

/// The paper's form is undefined exactly where the issue says: zero move, and tail on the line of motion
/// (pull and push), i.e. S × T = 0, sech⁻¹(0). The closed form needs no branch there.
#[test]
fn paper_form_breaks_on_the_line_of_motion() {
    let t = Vector3::new(-1.0, 0.0, 0.0); // tail behind the head along -x
    assert_eq!(
        tractrix_paper_step3(&t, &Vector3::zeros(), 1.0),
        Err(PaperFormDegenerate::ZeroMove)
    );
    // Pull: head moves away from the tail along the link.
    let pull = Vector3::new(0.3, 0.0, 0.0);
    assert_eq!(
        tractrix_paper_step3(&t, &pull, 1.0),
        Err(PaperFormDegenerate::Collinear)
    );
    let c = tractrix_step(&t, &pull, 1.0);
    assert_eq!(c.link, t, "a pulled collinear link translates");
    assert!((c.tail_shift - pull).norm() < 1e-16);
    // Push: head moves into the tail along the link; the tail stays ahead (unstable equilibrium).
    let push = Vector3::new(-0.3, 0.0, 0.0);
    assert_eq!(
        tractrix_paper_step3(&t, &push, 1.0),
        Err(PaperFormDegenerate::Collinear)
    );
    let c = tractrix_step(&t, &push, 1.0);
    assert!((c.link - t).norm() < 1e-15);
    assert!((c.tail_shift - push).norm() < 1e-15);
    // Push far enough that e^{-2b} underflows: still finite, still the collinear limit.
    let far = Vector3::new(-1e9, 0.0, 0.0);
    let c = tractrix_step(&t, &far, 1.0);
    assert_eq!(c.link, t);
    assert_eq!(c.tail_shift, far);
    // Planar embedding: same degeneracy in 2D.
    let r = tractrix_paper_step(&Vector2::new(0.0, -1.0), &Vector2::new(0.0, 2.0), 1.0);
    assert_eq!(r, Err(PaperFormDegenerate::Collinear));
}

/// Near the line of motion the paper's form is defined but loses digits: it needs sech⁻¹ of a tiny
/// number and a frame from a nearly zero cross product. Measure how close to the line it still agrees.
#[test]
fn paper_form_accuracy_near_the_line_of_motion() {
    let s = Vector3::new(0.5, 0.0, 0.0);
    for k in 1..=15 {
        let angle = 10f64.powi(-k);
        let t = Vector3::new(-angle.cos(), angle.sin(), 0.0);
        let c = tractrix_step(&t, &s, 1.0);
        let p = tractrix_paper_step3(&t, &s, 1.0).expect("defined off the line");
        let err = (c.link - p.link).norm();
        assert!(
            err <= 1e-12,
            "angle 1e-{k}: closed and paper differ by {err:e}"
        );
    }
}

/// Where the paper's form is defined but ill-conditioned (tail nearly perpendicular to the move), the
/// closed form stays on the ground truth while the paper's form drifts by about ε/(2|c|).
#[test]
fn paper_form_loses_digits_near_perpendicular() {
    let gt = GroundTruthOptions {
        rtol: 1e-14,
        atol: 1e-15,
    };
    let s = Vector3::new(0.0, 0.8, 0.0);
    let head = Vector3::zeros();
    for k in [4, 6, 8] {
        let c = -(10f64.powi(-k)); // tail just behind the perpendicular
        let t = Vector3::new((1.0 - c * c).sqrt(), c, 0.0);
        let truth = follow_path(&[head + t, head], 1, &[head + s], &gt).unwrap()[0];
        let closed = (t + tractrix_step(&t, &s, 1.0).tail_shift - truth).norm();
        let paper = (t + tractrix_paper_step3(&t, &s, 1.0).unwrap().tail_shift - truth).norm();
        assert!(
            closed < 1e-12,
            "c = {c:e}: closed form off the ground truth by {closed:e}"
        );
        if k == 8 {
            assert!(
                paper > 1e-10,
                "c = {c:e}: expected the paper form to lose digits, error {paper:e}"
            );
        }
    }
}

/// Closed form = continuous ground truth for one link, over random links and moves.
#[test]
fn closed_form_equals_ground_truth_for_one_link() {
    let mut rng = Rng(7);
    let gt = GroundTruthOptions {
        rtol: 1e-13,
        atol: 1e-14,
    };
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let t = rng.dir3();
        let s = rng.dir3() * rng.range(1e-3, 5.0);
        let head = Vector3::new(0.3, -0.2, 0.1);
        let pts = [head + t, head];
        let truth = follow_path(&pts, 1, &[head + s], &gt).unwrap();
        let c = tractrix_step(&t, &s, 1.0);
        let err = ((head + t + c.tail_shift) - truth[0]).norm();
        worst = worst.max(err);
    }
    assert!(
        worst < 1e-10,
        "worst difference to the ground truth {worst:e}"
    );
}

/// Follow-the-leader puts the tail on the line from the new head to the old tail, at the link length.
#[test]
fn follow_the_leader_definition() {
    let mut rng = Rng(11);
    for _ in 0..1000 {
        let t = rng.dir3() * 2.0;
        let s = rng.dir3() * rng.range(0.0, 3.0);
        let f = follow_the_leader_step(&t, &s, 2.0);
        assert!((f.link.norm() - 2.0).abs() < 1e-14);
        let r = t - s;
        assert!(f.link.normalize().dot(&r.normalize()) > 1.0 - 1e-14);
        assert!(((s + f.link - t) - f.tail_shift).norm() < 1e-13);
    }
    // Head landing exactly on the old tail: the link keeps its direction.
    let t = Vector3::new(1.0, 0.0, 0.0);
    let f = follow_the_leader_step(&t, &t, 1.0);
    assert_eq!(f.link, t);
}

/// A move of 1e-12 L: the displacement is accurate relative to itself (first-order tractrix velocity
/// (ḣ·e)e), not just to within rounding of the positions.
#[test]
fn tiny_moves_keep_relative_accuracy() {
    let mut rng = Rng(3);
    for _ in 0..1000 {
        let t = rng.dir3();
        let s = rng.dir3() * 1e-12;
        let e = t.normalize();
        let first_order = e * s.dot(&e);
        let c = tractrix_step(&t, &s, 1.0);
        // Second-order remainder is O(|s|²) = 1e-24; allow 1e-9 relative to |s|.
        assert!(
            (c.tail_shift - first_order).norm() <= 1e-9 * s.norm(),
            "{:?} vs {first_order:?}",
            c.tail_shift
        );
    }
}

/// A move of 1e9 link lengths: the closed form keeps the length to a few ulps; the paper's form, which
/// computes `x_r ≈ |S|` and then subtracts `|S|`, loses about ε·|S|/L of it.
#[test]
fn paper_form_loses_length_on_huge_moves() {
    let t = Vector3::new(-0.6f64, 0.8, 0.0);
    let s = Vector3::new(1e9f64, 3e8, -2e8);
    let c = tractrix_step(&t, &s, 1.0);
    let p = tractrix_paper_step3(&t, &s, 1.0).unwrap();
    assert!((c.link.norm() - 1.0).abs() <= 4.0 * f64::EPSILON);
    assert!(
        (c.link + s.normalize()).norm() <= 1e-15,
        "the tail ends straight behind the head"
    );
    assert!(
        (p.link.norm() - 1.0).abs() > 1e-9,
        "paper form length error {:e}",
        (p.link.norm() - 1.0).abs()
    );
}
