//! The write guard: access, range, EEPROM wear.

use std::time::{Duration, Instant};

use drive_profile::Access;
use movilink::guard::{GuardError, GuardWarning, WriteGuard};

#[test]
fn read_only_is_refused() {
    let mut g = WriteGuard::new();
    let e = g.check(8318, 0, true, Instant::now()).unwrap_err();
    assert!(matches!(e, GuardError::ReadOnly { index: 8318, .. }));
    let msg = e.to_string();
    assert!(msg.contains("read-only") && msg.contains("P000"), "{msg}");
    assert!(matches!(
        g.check(9999, 0, true, Instant::now()),
        Err(GuardError::UnknownIndex { index: 9999 })
    ));
}

#[test]
fn out_of_range_is_refused_with_the_range() {
    let mut g = WriteGuard::new();
    let now = Instant::now();
    let e = g.check(8470, 3_000_000, false, now).unwrap_err();
    assert!(
        matches!(
            e,
            GuardError::OutOfRange {
                index: 8470,
                raw: 3_000_000,
                min: 0,
                max: 2_000_000,
                ..
            }
        ),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("0 to 2000000") && msg.contains("--force"),
        "{msg}"
    );
    assert!(matches!(
        g.check(8598, 99, true, now),
        Err(GuardError::OutOfRange {
            min: 100,
            max: 199,
            ..
        })
    ));
    g.check(8598, 150, true, now).unwrap();
    g.check(8470, 2_000_000, true, now).unwrap();
}

#[test]
fn a_second_non_volatile_write_within_a_second_is_refused() {
    let mut g = WriteGuard::new();
    let t0 = Instant::now();
    g.check(8470, 1000, false, t0).unwrap();
    g.record(8470, false, t0);
    let e = g
        .check(8470, 1100, false, t0 + Duration::from_millis(400))
        .unwrap_err();
    assert!(
        matches!(e, GuardError::TooFrequent { index: 8470, .. }),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("--volatile") && msg.contains("EEPROM"),
        "{msg}"
    );
    // Other indices and later writes are fine.
    g.check(8471, 1100, false, t0 + Duration::from_millis(400))
        .unwrap();
    g.check(8470, 1100, false, t0 + Duration::from_secs(1))
        .unwrap();
}

#[test]
fn volatile_writes_are_never_rate_limited() {
    let mut g = WriteGuard::new();
    let t0 = Instant::now();
    g.record(8470, false, t0);
    for i in 0..100u32 {
        let t = t0 + Duration::from_millis(u64::from(i));
        g.check(8470, 1000, true, t).unwrap();
        g.record(8470, true, t);
    }
    // Volatile writes do not count for the EEPROM limit either.
    g.check(8470, 1000, false, t0 + Duration::from_millis(1000))
        .unwrap();
}

#[test]
fn parameters_needing_controller_inhibit_pass_with_a_warning() {
    let p = drive_profile::sew::params()
        .iter()
        .find(|p| p.access.contains(Access::NEEDS_INHIBIT) && p.access.is_writable())
        .unwrap();
    let g = WriteGuard::new();
    match g.warning(p.index) {
        Some(w @ GuardWarning::NeedsInhibit { .. }) => {
            assert!(w.to_string().contains("controller inhibit"));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(g.warning(8470), None);
}
