use super::*;

#[test]
fn a_pull_stop_reads_back_from_its_reason_and_nothing_else_does() {
    for p in PullStop::ALL {
        assert!(p.reason().len() < REASON_LEN);
        assert_eq!(PullStop::of(p.reason()), Some(p));
    }
    assert_eq!(PullStop::of(""), None);
    assert_eq!(PullStop::of("stopped short"), None);
    let mut h = ResponseHeader::default();
    h.set_reason(PullStop::Work.reason());
    h.status = Status::Ok as u32;
    assert_eq!(h.pull_stop(), Some(PullStop::Work));
    h.status = Status::Locked as u32;
    assert_eq!(h.pull_stop(), None);
}

/// The docs' table is what other languages are written from: it must say exactly what the types are.
#[test]
fn docs_layout_table_matches_the_types() {
    let src = include_str!("lib.rs");
    let start = src.find("<!-- layout-table-start -->").unwrap();
    let end = src.find("<!-- layout-table-end -->").unwrap();
    let rows: Vec<Vec<String>> = src[start..end]
        .lines()
        .map(|l| l.trim_start_matches("//!").trim())
        .filter(|l| l.starts_with('|') && !l.starts_with("|---") && !l.starts_with("| type"))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().trim_matches('`').to_string())
                .collect()
        })
        .collect();
    let mut expected = Vec::new();
    for t in WIRE_TYPES {
        for (i, f) in t.fields.iter().enumerate() {
            let head = if i == 0 {
                format!("{} ({} B, align {})", t.name, t.size, t.align)
            } else {
                String::new()
            };
            expected.push(vec![
                head,
                f.name.to_string(),
                f.offset.to_string(),
                f.c_type.to_string(),
            ]);
        }
    }
    assert_eq!(rows, expected);
}

/// Fields tile each type without gaps: no implicit padding a C compiler could place differently.
#[test]
fn wire_types_have_no_implicit_padding() {
    fn c_size(c: &str) -> usize {
        let (base, count) = match c.split_once('[') {
            Some((b, n)) => (b, n.trim_end_matches(']').parse::<usize>().unwrap()),
            None => (c, 1),
        };
        let s = match base {
            "double" | "uint64_t" => 8,
            "uint32_t" => 4,
            "uint8_t" => 1,
            other => panic!("unknown C type {other}"),
        };
        s * count
    }
    for t in WIRE_TYPES {
        let mut at = 0;
        for f in t.fields {
            assert_eq!(f.offset, at, "{}.{} leaves a gap", t.name, f.name);
            at += c_size(f.c_type);
        }
        assert_eq!(at, t.size, "{} has tail padding", t.name);
    }
}

#[test]
fn enums_round_trip_and_reject_unknown_values() {
    for c in Command::ALL {
        assert_eq!(Command::from_u32(c as u32), Some(c));
    }
    for s in Status::ALL {
        assert_eq!(Status::from_u32(s as u32), Some(s));
    }
    assert_eq!(Command::from_u32(0), None);
    assert_eq!(Command::from_u32(8), Some(Command::Grasp));
    assert_eq!(Command::from_u32(9), Some(Command::Release));
    assert_eq!(Command::from_u32(10), Some(Command::Instrument));
    assert_eq!(Command::from_u32(11), Some(Command::Eyelet));
    assert_eq!(Command::from_u32(12), None);
    assert_eq!(Status::from_u32(14), Some(Status::Locked));
    assert_eq!(Status::from_u32(15), Some(Status::TooFar));
    assert_eq!(Status::from_u32(16), Some(Status::OverBudget));
    assert_eq!(Status::from_u32(17), Some(Status::JointLimit));
    assert_eq!(Status::from_u32(18), Some(Status::Held));
    assert_eq!(Status::from_u32(19), None);
    assert_eq!(WireMethod::from_u32(4), None);
    assert_eq!(Precision::from_u32(2), Some(Precision::F32));
}

#[test]
fn strings_are_cut_at_char_boundaries_and_keep_a_nul() {
    let mut h = ResponseHeader::default();
    h.set_reason(&"é".repeat(100));
    assert!(h.reason.contains(&0));
    assert_eq!(h.reason_str(), "é".repeat(47));
    h.set_name("rope");
    assert_eq!(h.name_str(), "rope");
    let mut r = RequestHeader::default();
    r.set_listener_id(0x0123_4567_89ab_cdef_fedc_ba98_7654_3210);
    assert_eq!(r.listener_id(), 0x0123_4567_89ab_cdef_fedc_ba98_7654_3210);
}
