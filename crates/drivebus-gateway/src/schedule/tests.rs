use super::super::task::fake::plant;
use super::*;

/// Wire time of a read and a write in these tests; process data takes half.
const W: Duration = Duration::from_millis(2);

fn wire(op: Op) -> Duration {
    match op {
        Op::ProcessData(_) => W / 2,
        _ => W,
    }
}

/// What a simulated run did: each job and when it started.
struct Run {
    started: Vec<(Instant, Job)>,
    figures: BusFigures,
}

/// Drive the scheduler of `bus` for `dur` as a bus would: each job takes its wire time,
/// a job of a drive `dead(drive, now)` says is dead takes the bus's timeout × (retries + 1).
fn simulate(
    bus: &Bus,
    dur: Duration,
    writes: &[(Duration, DriveIx)],
    dead: impl Fn(DriveIx, Duration) -> bool,
) -> Run {
    let t0 = Instant::now();
    let mut s: Scheduler<usize> = Scheduler::new(bus, wire, t0);
    let mut now = t0;
    let mut started = Vec::new();
    let mut pending: Vec<(Duration, DriveIx)> = writes.to_vec();
    let end = t0 + dur;
    while now < end {
        pending.retain(|&(at, d)| {
            if t0 + at <= now {
                s.push_write(d, now, Duration::from_secs(10), d);
                false
            } else {
                true
            }
        });
        let (job, took) = match s.next(now) {
            Next::Idle(until) => {
                let next_write = pending.iter().map(|w| t0 + w.0).min();
                now = next_write.map_or(until, |w| w.min(until)).min(end).max(now);
                continue;
            }
            Next::Refuse { .. } => continue,
            Next::Run(job) => (job, wire(job.op(bus))),
            Next::Write { drive, .. } => (Job::Write { drive }, W * 2),
        };
        started.push((now, job));
        let outcome = if dead(job.drive(), now - t0) {
            now += bus.timeout * (u32::from(bus.retries) + 1);
            Outcome::NoAnswer
        } else {
            now += took;
            Outcome::Answered
        };
        s.done(job, now, outcome);
    }
    Run {
        started,
        figures: s.figures(now),
    }
}

fn starts_of(run: &Run, job: Job) -> Vec<Instant> {
    run.started
        .iter()
        .filter(|(_, j)| *j == job)
        .map(|(t, _)| *t)
        .collect()
}

fn ten_by_three(period: &str) -> Bus {
    let p = Some(period);
    plant(
        10,
        &[("a", p, false), ("b", p, false), ("c", p, true)],
        None,
        "",
    )
    .buses
    .remove(0)
}

#[test]
fn process_data_first_then_a_write_then_polls_by_due_time_then_status_reads() {
    let bus = plant(
        2,
        &[("a", Some("1s"), true), ("b", Some("2s"), false)],
        Some("1s"),
        "status_period = \"5s\"\n",
    )
    .buses
    .remove(0);
    let t0 = Instant::now();
    let mut s: Scheduler<u32> = Scheduler::new(&bus, wire, t0);
    // Everything is due at 10 s; two writes wait.
    let mut now = t0 + Duration::from_secs(10);
    s.push_write(1, now, Duration::from_secs(60), 1);
    s.push_write(0, now, Duration::from_secs(60), 2);
    let mut order = Vec::new();
    for _ in 0..10 {
        let job = match s.next(now) {
            Next::Run(job) => job,
            Next::Write { drive, write } => {
                order.push(format!("write{write}"));
                now += W;
                s.done(Job::Write { drive }, now, Outcome::Answered);
                continue;
            }
            other => panic!("{other:?}"),
        };
        order.push(match job {
            Job::ProcessData { drive } => format!("pd{drive}"),
            Job::Poll { drive, point } => format!("poll{drive}.{point}"),
            Job::Status { drive } => format!("status{drive}"),
            other => panic!("{other:?}"),
        });
        now += W;
        s.done(job, now, Outcome::Answered);
    }
    // The polls in the order of their due times (spread: the 1 s jobs pd0, pd1, a0, a1 at
    // 0, 250, 500, 750 ms; the 2 s jobs b0, b1 at 1 ms and 1001 ms), and a write goes
    // ahead of due polls but not twice in a row.
    assert_eq!(
        order,
        [
            "pd0", "pd1", "write1", "poll0.1", "write2", "poll0.0", "poll1.0", "poll1.1",
            "status0", "status1"
        ],
        "{order:?}"
    );
}

#[test]
fn a_write_older_than_its_max_age_is_refused_and_never_run() {
    let bus = ten_by_three("100ms");
    let t0 = Instant::now();
    let mut s: Scheduler<u32> = Scheduler::new(&bus, wire, t0);
    s.push_write(3, t0, Duration::from_millis(50), 7);
    match s.next(t0 + Duration::from_millis(51)) {
        Next::Refuse {
            write: 7,
            reason: Refusal::Expired,
        } => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(s.writes_waiting(), 0);
    // A write of an offline drive is refused as such.
    let now = t0 + Duration::from_millis(60);
    let Next::Run(job) = s.next(now) else {
        panic!("a poll is due")
    };
    assert_eq!(
        s.done(job, now + Duration::from_millis(200), Outcome::NoAnswer),
        Some(Change::WentOffline)
    );
    s.push_write(job.drive(), now, Duration::from_secs(10), 8);
    assert!(matches!(
        s.next(now + Duration::from_millis(201)),
        Next::Refuse {
            write: 8,
            reason: Refusal::Offline
        }
    ));
}

#[test]
fn polls_are_spread_over_their_period_without_a_burst_at_start_or_after_a_period() {
    // 30 polls of 100 ms and 10 status reads of 5 s, 2 ms each: 3 polls per 10 ms.
    let bus = ten_by_three("100ms");
    let run = simulate(&bus, Duration::from_secs(2), &[], |_, _| false);
    let t0 = run.started.first().map(|s| s.0).unwrap();
    // The i-th poll starts in its even share of the period (100 ms / 30 polls), in the
    // first period as in every later one: all at start would be 30 back to back.
    let polls: Vec<Duration> = run
        .started
        .iter()
        .filter(|(_, j)| matches!(j, Job::Poll { .. }))
        .map(|(t, _)| *t - t0)
        .collect();
    assert_eq!(polls.len(), 600);
    for (i, t) in polls.iter().enumerate() {
        let slot = Duration::from_millis(100) * (i as u32) / 30;
        assert!(
            t.abs_diff(slot) <= W * 2,
            "poll {i} at {t:?}, its slot {slot:?}"
        );
    }
    // Every poll keeps its period within one wire time.
    for d in 0..10 {
        for p in 0..3 {
            let starts = starts_of(&run, Job::Poll { drive: d, point: p });
            assert_eq!(starts.len(), 20);
            for pair in starts.windows(2) {
                let gap = pair[1] - pair[0];
                assert!(
                    gap.abs_diff(Duration::from_millis(100)) <= W,
                    "drive {d} point {p}: {gap:?}"
                );
            }
        }
    }
    assert_eq!(run.figures.late_polls, 0);
}

#[test]
fn utilisation_is_the_demand_below_the_wire_bound() {
    let bus = ten_by_three("100ms");
    let run = simulate(&bus, Duration::from_secs(20), &[], |_, _| false);
    // 30 × 2 ms / 100 ms + 10 × 2 ms / 5 s.
    let demand = 0.6 + 0.004;
    assert!(
        (run.figures.demand - demand).abs() < 1e-9,
        "{:?}",
        run.figures
    );
    assert!(
        (run.figures.utilisation - demand).abs() < 0.01,
        "{:?}",
        run.figures
    );
    assert_eq!(run.figures.transactions as usize, run.started.len());
}

#[test]
fn polls_asking_more_than_the_wire_are_stretched_evenly_and_counted_late() {
    // 30 polls of 2 ms every 40 ms: 150 % (+ status reads).
    let bus = ten_by_three("40ms");
    let t0 = Instant::now();
    let s: Scheduler<()> = Scheduler::new(&bus, wire, t0);
    let stretch = s.stretch();
    assert!((stretch - 1.504).abs() < 1e-9, "{stretch}");
    let run = simulate(&bus, Duration::from_secs(10), &[], |_, _| false);
    // The wire is full, never more than full.
    assert!(
        run.figures.utilisation > 0.98 && run.figures.utilisation <= 1.0 + 1e-9,
        "{:?}",
        run.figures
    );
    // Every poll gets the same stretched period.
    let stretched = Duration::from_millis(40).mul_f64(stretch);
    for d in 0..10 {
        for p in 0..3 {
            let starts = starts_of(&run, Job::Poll { drive: d, point: p });
            let mean = (starts[starts.len() - 1] - starts[0]) / (starts.len() as u32 - 1);
            assert!(mean.abs_diff(stretched) <= W, "{d}.{p}: {mean:?}");
        }
    }
    let polls = run
        .started
        .iter()
        .filter(|(_, j)| matches!(j, Job::Poll { .. }))
        .count() as u64;
    assert!(
        run.figures.late_polls >= polls * 9 / 10,
        "{:?} of {polls}",
        run.figures
    );
}

#[test]
fn an_offline_drive_costs_one_timeout_then_probes_with_a_back_off_and_others_keep_their_periods() {
    // Drive 0 is dead from 1 s to 31 s.
    let bus = ten_by_three("100ms");
    let dead = |d: DriveIx, t: Duration| {
        d == 0 && t >= Duration::from_secs(1) && t < Duration::from_secs(31)
    };
    let run = simulate(&bus, Duration::from_secs(40), &[], dead);
    let t0 = run.started[0].0;
    let drive0: Vec<(Duration, Job)> = run
        .started
        .iter()
        .filter(|(t, j)| j.drive() == 0 && dead(0, *t - t0))
        .map(|(t, j)| (*t - t0, *j))
        .collect();
    // One timeout, then probes after 1, 2, 4, 8, 10, … s (each probe takes 200 ms).
    let timeout = bus.timeout * 2;
    assert!(!matches!(drive0[0].1, Job::Probe { .. }));
    let gaps: Vec<Duration> = drive0.windows(2).map(|w| w[1].0 - w[0].0).collect();
    let expected: Vec<Duration> = [1, 2, 4, 8, 10]
        .iter()
        .map(|s| Duration::from_secs(*s) + timeout)
        .collect();
    for (gap, want) in gaps.iter().zip(&expected) {
        // The probe waits at most for the poll on the wire and one due before it.
        assert!(*gap >= *want && *gap <= *want + W * 2, "{drive0:?}");
    }
    assert!(gaps.len() >= 5, "{drive0:?}");
    assert!(
        drive0[1..]
            .iter()
            .all(|(_, j)| matches!(j, Job::Probe { .. }))
    );
    // Probes at 2.2, 4.4, 8.6, 16.8, 27.0 s (each 200 ms), back at 31 s: the probe at
    // 37.2 s is answered and its polls resume, each once per period.
    let after: Vec<Duration> = starts_of(&run, Job::Poll { drive: 0, point: 0 })
        .iter()
        .map(|t| *t - t0)
        .filter(|t| *t > Duration::from_secs(31))
        .collect();
    assert!(after[0] > Duration::from_millis(37_200), "{after:?}");
    assert!((27..=29).contains(&after.len()), "{after:?}");
    // The others keep their periods: on average within a wire time, and no gap longer
    // than a period plus the one timeout or probe in it.
    for d in 1..10 {
        let starts = starts_of(&run, Job::Poll { drive: d, point: 1 });
        let mean = (starts[starts.len() - 1] - starts[0]) / (starts.len() as u32 - 1);
        assert!(
            mean.abs_diff(Duration::from_millis(100)) <= W,
            "{d}: {mean:?}"
        );
        for pair in starts.windows(2) {
            assert!(pair[1] - pair[0] <= Duration::from_millis(100) + timeout + W);
        }
    }
}
