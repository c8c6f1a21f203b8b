//! Helpers shared by the kernel tests.

use nalgebra::{SVector, Vector3};
use tractrix::{Chain, Real};

/// Largest relative deviation of a link vector's length from its nominal length.
pub fn max_length_error<T: Real, const D: usize>(chain: &Chain<T, D>) -> f64
where
    SVector<T, D>: tractrix::math::Embed3<T>,
{
    chain
        .links()
        .iter()
        .zip(chain.lengths())
        .map(|(l, &len)| ((l.norm() - len) / len).to_f64().abs())
        .fold(0.0, f64::max)
}

/// Largest relative deviation of the distance between consecutive *published* positions.
pub fn max_position_length_error<T: Real, const D: usize>(chain: &Chain<T, D>) -> f64
where
    SVector<T, D>: tractrix::math::Embed3<T>,
{
    let p = chain.positions();
    p.windows(2)
        .zip(chain.lengths())
        .map(|(w, &len)| (((w[1] - w[0]).norm() - len) / len).to_f64().abs())
        .fold(0.0, f64::max)
}

/// A small deterministic generator (SplitMix64) so failures reproduce from the seed printed.
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// A uniformly random unit vector in 3D.
    pub fn dir3(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let n = v.norm();
            if n > 1e-3 && n <= 1.0 {
                return v / n;
            }
        }
    }
}
