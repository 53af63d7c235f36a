use super::*;
use crate::client::DeviceErrorKind;
use crate::testing::{FakeClient, refusal};
use drive_profile::Family;
use std::cell::RefCell;

const MS: Duration = Duration::from_millis(1);

fn at(secs: i64, millis: u64) -> SystemTime {
    let base = if secs >= 0 {
        UNIX_EPOCH + Duration::from_secs(secs.unsigned_abs())
    } else {
        UNIX_EPOCH - Duration::from_secs(secs.unsigned_abs())
    };
    base + Duration::from_millis(millis)
}

#[test]
fn timestamps_are_rfc3339_utc_with_milliseconds() {
    assert_eq!(timestamp(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
    assert_eq!(timestamp(at(951_782_400, 0)), "2000-02-29T00:00:00.000Z");
    assert_eq!(
        timestamp(at(1_709_210_096, 789)),
        "2024-02-29T12:34:56.789Z"
    );
    assert_eq!(timestamp(at(4_107_542_400, 1)), "2100-03-01T00:00:00.001Z");
    assert_eq!(
        timestamp(at(253_402_300_799, 999)),
        "9999-12-31T23:59:59.999Z"
    );
    // Before 1970: 1900 was not a leap year.
    assert_eq!(timestamp(at(-2_203_891_200, 0)), "1900-03-01T00:00:00.000Z");
    assert_eq!(
        timestamp(UNIX_EPOCH - Duration::from_millis(1)),
        "1969-12-31T23:59:59.999Z"
    );
    // Every day of 400 years follows the one before it.
    let mut prev = civil_from_days(-1);
    for day in 0..146_097 {
        let (y, m, d) = civil_from_days(day);
        let next_day = (y, m, d) > prev && (d == prev.2 + 1 || d == 1);
        assert!(next_day, "day {day}: {prev:?} -> {:?}", (y, m, d));
        prev = (y, m, d);
    }
    assert_eq!(prev, (2369, 12, 31));
}

thread_local! {
    /// When the fake drive was asked, on tokio's (paused) clock.
    static ASKED: RefCell<Vec<Instant>> = const { RefCell::new(Vec::new()) };
}

/// P000 answers 1500 1/min and notes the time; P130 is refused; index 9999 reads -5; anything
/// else finds no drive.
fn drive(index: u16) -> Result<i64, ClientError> {
    match index {
        8318 => {
            ASKED.with(|a| a.borrow_mut().push(time::now()));
            Ok(1_500_000)
        }
        8470 => Err(refusal(DeviceErrorKind::Refused, "parameter lock")),
        9999 => Ok(-5),
        _ => Err(ClientError::link(
            crate::LinkFault::NoAnswer,
            "no answer from drive 1",
        )),
    }
}

fn targets(keys: &[&str]) -> Vec<Target> {
    keys.iter()
        .map(|k| Target::resolve(Family::Movidrive, k, 1000..=0xFFFF).unwrap())
        .collect()
}

#[tokio::test(start_paused = true)]
async fn polls_keep_their_rhythm_and_carry_values_and_refusals() {
    ASKED.with(|a| a.borrow_mut().clear());
    let start = time::now();
    let mut client: FakeClient = FakeClient::new(drive);
    let targets = targets(&["P000", "P130", "9999"]);
    let mut s = Sampler::new(&mut client, &targets, 200 * MS, 3);
    let mut samples = Vec::new();
    while let Some(sample) = s.next().await.unwrap() {
        samples.push(sample);
    }
    let asked = ASKED.with(|a| a.borrow().clone());
    let offsets: Vec<Duration> = asked.iter().map(|t| *t - start).collect();
    assert_eq!(offsets, [Duration::ZERO, 200 * MS, 400 * MS]);
    let polls: Vec<u64> = samples.iter().map(|s| s.poll).collect();
    assert_eq!(polls, [1, 2, 3]);
    for (sample, asked) in samples.iter().zip(&asked) {
        assert_eq!(sample.at, *asked);
        assert_eq!(sample.values[0], Ok(1_500_000));
        assert_eq!(
            sample.values[1].as_ref().map_err(|d| d.message.as_str()),
            Err("parameter lock")
        );
        assert_eq!(sample.values[2], Ok(-5));
        // As JSON: the time, each read's object, a refusal with the keys of its target.
        let v = sample.to_json(&targets);
        assert_eq!(v["type"], "sample");
        assert_eq!(v["time"], timestamp(sample.time));
        assert_eq!(v["values"][0]["number"], "P000");
        assert_eq!(v["values"][0]["value"], 1500.0);
        let refused = &v["values"][1];
        assert_eq!(
            (&refused["label"], &refused["error"]),
            (&"P130".into(), &"parameter lock".into())
        );
        assert_eq!(refused["name_en"], "Ramp t11 up CW [s]");
        assert!(refused["selector"].is_null());
        assert_eq!(v["values"][2]["raw"], -5);
    }
    // P130 was refused in every poll: named with the drive's answer.
    assert_eq!(s.polls(), 3);
    let unread: Vec<(String, String)> = s
        .unread()
        .into_iter()
        .map(|(t, d)| (t.label(), d.message))
        .collect();
    assert_eq!(unread, [("P130".to_owned(), "parameter lock".to_owned())]);
    let verdict = s.verdict().unwrap_err();
    assert!(!verdict.none_read());
    assert_eq!(
        verdict.to_string(),
        "1 of 3 parameter(s) could not be read in any of the 3 poll(s): P130 (parameter lock)"
    );
}

#[tokio::test(start_paused = true)]
async fn a_cancelled_poll_leaves_the_sampler_usable_and_counts_only_complete_polls() {
    let mut client: FakeClient = FakeClient::new(drive);
    let targets = targets(&["P000"]);
    let mut s = Sampler::new(&mut client, &targets, 200 * MS, 0);
    let mut polls = 0;
    let stop = tokio::time::sleep(700 * MS);
    tokio::pin!(stop);
    loop {
        tokio::select! {
            r = s.next() => { r.unwrap().unwrap(); polls += 1; }
            () = &mut stop => break,
        }
    }
    // Polls at 0, 200, 400 and 600 ms; the stop at 700 ms ends it while it waits.
    assert_eq!((polls, s.polls()), (4, 4));
    assert!(s.unread().is_empty());
}

#[tokio::test(start_paused = true)]
async fn a_link_failure_ends_the_watch_and_nothing_is_judged_before_a_poll() {
    let mut client: FakeClient = FakeClient::new(drive);
    let targets = targets(&["P130", "P001"]);
    let mut s = Sampler::new(&mut client, &targets, 200 * MS, 3);
    let Err(WatchError::Link {
        target,
        error,
        polls,
    }) = s.next().await
    else {
        panic!("the link failure ends the watch");
    };
    assert_eq!((target.label(), polls), ("P001".to_owned(), 0));
    assert_eq!(
        error,
        ClientError::link(crate::LinkFault::NoAnswer, "no answer from drive 1")
    );
    // P130 was refused, but no poll was complete.
    assert!(s.unread().is_empty() && s.verdict().is_ok());
}
