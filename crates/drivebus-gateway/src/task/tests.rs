use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

use serde_json::json;
use tokio::sync::oneshot;
use tokio::time::sleep;

use super::fake::{FakeBus, State, plant};
use super::*;
use crate::config::Plant;
use crate::model::BusFigures;

const WIRE: Duration = Duration::from_millis(5);
/// P130's bus index.
const P130: u16 = 8470;

struct Harness {
    sets: mpsc::Sender<SetRequest>,
    /// The page's requests.
    asks: mpsc::Sender<Ask>,
    /// The gateway's stop.
    stop: tokio::sync::watch::Sender<crate::bus::Stop>,
    /// The bus task.
    task: tokio::task::JoinHandle<()>,
    state: Rc<RefCell<State>>,
    /// Every update with the (virtual) time it arrived.
    seen: Rc<RefCell<Vec<(Instant, Update)>>>,
    t0: Instant,
}

fn start(plant: &Plant) -> Harness {
    let bus = plant.buses[0].clone();
    let (fake, state) = FakeBus::new(&bus, WIRE);
    let (utx, mut urx) = mpsc::channel(4096);
    let (stx, srx) = mpsc::channel(64);
    let (atx, arx) = mpsc::channel(64);
    let (stop, shutdown) = tokio::sync::watch::channel(crate::bus::Stop::Run);
    let ctx = BusContext {
        ix: crate::model::BusSlot::new(0),
        bus,
        updates: utx,
        sets: srx,
        asks: arx,
        metrics: Arc::new(Metrics::new(plant)),
        shutdown,
        announce: crate::bus::BusContext::no_announce(),
    };
    let task = tokio::task::spawn_local(run_bus(ctx, fake));
    let seen = Rc::new(RefCell::new(Vec::new()));
    let log = seen.clone();
    tokio::task::spawn_local(async move {
        while let Some(u) = urx.recv().await {
            log.borrow_mut().push((Instant::now(), u));
        }
    });
    Harness {
        sets: stx,
        asks: atx,
        stop,
        task,
        state,
        seen,
        t0: Instant::now(),
    }
}

impl Harness {
    async fn set_at(
        &self,
        drive: DriveIx,
        point: usize,
        value: SetValue,
        received: Instant,
        max_age: Duration,
    ) -> SetOutcome {
        let (reply, rx) = oneshot::channel();
        let req = SetRequest {
            drive,
            point,
            value,
            received,
            max_age,
            reply,
        };
        self.sets.send(req).await.unwrap();
        rx.await.unwrap()
    }

    async fn set(&self, drive: DriveIx, point: usize, value: SetValue) -> SetOutcome {
        self.set_at(drive, point, value, Instant::now(), Duration::from_secs(10))
            .await
    }

    /// Status updates of `drive`: when (since start) and which.
    fn statuses(&self, drive: DriveIx) -> Vec<(Duration, DriveStatus)> {
        self.seen
            .borrow()
            .iter()
            .filter_map(|(t, u)| match u {
                Update::Status {
                    drive: d, status, ..
                } if *d == drive => Some((*t - self.t0, status.clone())),
                _ => None,
            })
            .collect()
    }

    /// When values of `drive`'s `point` arrived.
    fn values(&self, drive: DriveIx, point: usize) -> Vec<(Instant, i64)> {
        self.seen
            .borrow()
            .iter()
            .filter_map(|(t, u)| match u {
                Update::Value {
                    drive: d,
                    point: p,
                    raw,
                    ..
                } if *d == drive && *p == point => Some((*t, *raw)),
                _ => None,
            })
            .collect()
    }
}

/// The reason of a refusal (one `/metrics` counts under its own name).
fn refused(outcome: &SetOutcome) -> &'static str {
    match outcome {
        SetOutcome::Refused { reason, .. } => {
            let known = &crate::metrics::SET_OUTCOMES;
            assert!(
                known[..known.len() - 1].contains(reason),
                "{reason} is not in metrics::SET_OUTCOMES"
            );
            reason
        }
        other => panic!("not refused: {other:?}"),
    }
}

/// Three drives, each with P130 polled every 100 ms (writable) and P130 as "fixed"
/// (polled, not writable).
fn three() -> Plant {
    plant(
        3,
        &[("ramp", Some("100ms"), true), ("fixed", Some("1s"), false)],
        None,
        "status_period = \"1s\"\n",
    )
}

/// At the gateway's stop the task finishes, sending each process-data drive that answers
/// its stop (and none to a drive that is offline), then returns.
#[tokio::test(start_paused = true)]
async fn at_the_stop_every_answering_process_data_drive_gets_its_stop() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = plant(
                3,
                &[("ramp", Some("100ms"), true)],
                Some("20ms"),
                "status_period = \"1s\"\n",
            );
            let h = start(&plant);
            h.state.borrow_mut().dead.insert(3);
            sleep(Duration::from_secs(3)).await;
            assert!(h.state.borrow().stopped.is_empty());
            h.stop.send(crate::bus::Stop::Gateway).unwrap();
            let done = tokio::time::timeout(Duration::from_secs(5), h.task).await;
            assert!(
                matches!(done, Ok(Ok(()))),
                "the task returns after the stop"
            );
            let stopped = h.state.borrow().stopped.clone();
            assert_eq!(stopped, vec![(1, vec![6, 1000]), (2, vec![6, 1000])]);
        })
        .await;
}

/// Issue 22, item 2: a bus a reload restarts or removes returns without stopping the drives
/// whose process data the new config carries on on the same line (its task sends their next
/// cycle), and stops every other drive it controls, as at the gateway's stop.
#[tokio::test(start_paused = true)]
async fn a_bus_retired_by_a_reload_stops_only_the_drives_the_new_config_does_not_carry_on() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = plant(
                3,
                &[("ramp", Some("100ms"), true)],
                Some("20ms"),
                "status_period = \"1s\"\n",
            );
            let h = start(&plant);
            sleep(Duration::from_secs(3)).await;
            h.stop
                .send(crate::bus::Stop::Retire { continued: vec![2] })
                .unwrap();
            let done = tokio::time::timeout(Duration::from_secs(5), h.task).await;
            assert!(matches!(done, Ok(Ok(()))), "the task returns");
            let stopped = h.state.borrow().stopped.clone();
            assert_eq!(stopped, vec![(1, vec![6, 1000]), (3, vec![6, 1000])]);
        })
        .await;
}

#[tokio::test(start_paused = true)]
async fn a_dead_drive_goes_timeout_within_period_and_timeout_and_online_when_it_returns() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let bus = &plant.buses[0];
            let h = start(&plant);
            sleep(Duration::from_secs(2)).await;
            // All online from their first answer, once.
            for d in 0..3 {
                assert_eq!(h.statuses(d).len(), 1, "{:?}", h.statuses(d));
                assert_eq!(h.statuses(d)[0].1, DriveStatus::Online);
            }
            let killed = Instant::now() - h.t0;
            h.state.borrow_mut().dead.insert(2);
            sleep(Duration::from_secs(20)).await;
            let back = Instant::now() - h.t0;
            h.state.borrow_mut().dead.remove(&2);
            sleep(Duration::from_secs(12)).await;
            let st = h.statuses(1);
            let bound = Duration::from_millis(100) + bus.timeout * (u32::from(bus.retries) + 1);
            match &st[..] {
                [
                    (_, DriveStatus::Online),
                    (t1, DriveStatus::Timeout),
                    (t2, DriveStatus::Online),
                ] => {
                    assert!(
                        *t1 - killed <= bound + WIRE,
                        "timeout after {:?}",
                        *t1 - killed
                    );
                    // The probe after at most the longest back-off brings it back.
                    assert!(
                        *t2 > back && *t2 - back <= Duration::from_secs(10) + bound,
                        "{st:?}"
                    );
                }
                _ => panic!("{st:?}"),
            }
            // The others kept their period: each 100 ms poll on time (within the one
            // timeout or probe that held the bus), never marked offline.
            for d in [0, 2] {
                assert_eq!(h.statuses(d).len(), 1);
                let v = h.values(d, 0);
                let n = v.len();
                let mean = (v[n - 1].0 - v[0].0) / (n as u32 - 1);
                assert!(
                    mean.abs_diff(Duration::from_millis(100)) <= WIRE,
                    "{mean:?}"
                );
                for w in v.windows(2) {
                    assert!(w[1].0 - w[0].0 <= Duration::from_millis(100) + bound + WIRE);
                }
            }
            // One timeout of the dead drive, then probes only: 1 + 1 + 2 + 4 + 8 + 10 s.
            let log = h.state.borrow().log.clone();
            let dead_tx = log
                .iter()
                .filter(|(t, a, _)| *a == 2 && *t - h.t0 >= killed && *t - h.t0 < back)
                .count();
            assert!((5..=7).contains(&dead_tx), "{dead_tx}");
            // Figures every 5 s, with the link's retries (one per dead attempt).
            let figures: Vec<BusFigures> = h
                .seen
                .borrow()
                .iter()
                .filter_map(|(_, u)| match u {
                    Update::Figures { figures, .. } => Some(figures.clone()),
                    _ => None,
                })
                .collect();
            assert_eq!(figures.len(), 6, "{figures:?}");
            let last = figures.last().unwrap();
            assert_eq!(last.retries, last.timeouts);
            assert!(last.timeouts as usize == dead_tx, "{last:?}");
        })
        .await;
}

#[tokio::test(start_paused = true)]
async fn a_status_is_reported_only_when_it_changes() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let h = start(&plant);
            sleep(Duration::from_secs(3)).await;
            h.state
                .borrow_mut()
                .faults
                .insert(1, "F07 DC link overvoltage".into());
            sleep(Duration::from_secs(3)).await;
            h.state.borrow_mut().faults.clear();
            sleep(Duration::from_secs(3)).await;
            let st: Vec<DriveStatus> = h.statuses(0).into_iter().map(|s| s.1).collect();
            assert_eq!(
                st,
                [
                    DriveStatus::Online,
                    DriveStatus::Fault("F07 DC link overvoltage".into()),
                    DriveStatus::Online
                ]
            );
            assert_eq!(h.statuses(1).len(), 1);
        })
        .await;
}

#[tokio::test(start_paused = true)]
async fn writes_are_guarded_converted_written_and_read_back() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let h = start(&plant);
            sleep(Duration::from_millis(500)).await;
            // A value in the unit (1.5 s), then a raw one: written, read back, published.
            let o = h.set(0, 0, SetValue::Value(json!(1.5))).await;
            assert_eq!(
                o,
                SetOutcome::Written {
                    raw: 1500,
                    differs: None
                }
            );
            let o = h.set(0, 0, SetValue::Value(json!("2,5"))).await;
            assert_eq!(
                o,
                SetOutcome::Written {
                    raw: 2500,
                    differs: None
                }
            );
            let o = h.set(1, 0, SetValue::Raw(2000)).await;
            assert_eq!(
                o,
                SetOutcome::Written {
                    raw: 2000,
                    differs: None
                }
            );
            assert!(h.values(1, 0).iter().any(|v| v.1 == 2000));
            assert_eq!(
                h.state.borrow().written,
                [
                    (1, P130, 1500, Persistence::Volatile),
                    (1, P130, 2500, Persistence::Volatile),
                    (2, P130, 2000, Persistence::Volatile)
                ]
            );
            // Nothing a set carries is written when it is wrong, and none panics.
            let bad: Vec<(SetValue, &str)> = vec![
                (SetValue::Value(json!(3000)), "range"),
                (SetValue::Value(json!(-1)), "range"),
                (SetValue::Value(json!(1e300)), "range"),
                (SetValue::Value(json!(u64::MAX)), "range"),
                (SetValue::Value(json!(1.25)), "resolution"),
                (SetValue::Raw(1 << 40), "width"),
                (SetValue::Raw(i64::MIN), "width"),
                (SetValue::Raw(99_999_999), "range"),
                (SetValue::Value(json!(null)), "bad_request"),
                (SetValue::Value(json!(true)), "bad_request"),
                (SetValue::Value(json!([1])), "bad_request"),
                (SetValue::Value(json!({"a": 1})), "bad_request"),
                (SetValue::Value(json!("fast")), "bad_request"),
                (SetValue::Value(json!("NaN")), "bad_request"),
                (SetValue::Value(json!("1e3")), "bad_request"),
                (SetValue::Value(json!("9".repeat(100_000))), "bad_request"),
            ];
            for (value, reason) in bad {
                let o = h.set(0, 0, value.clone()).await;
                assert_eq!(refused(&o), reason, "{value:?}: {o:?}");
            }
            // Not writable; no such drive or point.
            assert_eq!(
                refused(&h.set(0, 1, SetValue::Raw(1500)).await),
                "not_writable"
            );
            assert_eq!(
                refused(&h.set(7, 0, SetValue::Raw(1500)).await),
                "bad_request"
            );
            assert_eq!(
                refused(&h.set(0, 9, SetValue::Raw(1500)).await),
                "bad_request"
            );
            // Too old on arrival.
            let old = Instant::now() - Duration::from_secs(20);
            let o = h
                .set_at(0, 0, SetValue::Raw(1500), old, Duration::from_secs(10))
                .await;
            assert_eq!(refused(&o), "expired");
            assert_eq!(h.state.borrow().written.len(), 3);
            // The drive refuses it.
            h.state.borrow_mut().refuse_writes.insert(P130);
            match h.set(2, 0, SetValue::Raw(1500)).await {
                SetOutcome::DeviceRefused { message } => {
                    assert!(message.contains("controller inhibit"), "{message}")
                }
                other => panic!("{other:?}"),
            }
            assert_eq!(h.state.borrow().written.len(), 3);
        })
        .await;
}

#[tokio::test(start_paused = true)]
async fn writes_for_an_offline_drive_or_waiting_too_long_are_refused_and_never_sent() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let h = start(&plant);
            sleep(Duration::from_millis(500)).await;
            h.state.borrow_mut().dead.insert(3);
            sleep(Duration::from_secs(1)).await;
            assert_eq!(h.statuses(2).last().unwrap().1, DriveStatus::Timeout);
            assert_eq!(refused(&h.set(2, 0, SetValue::Raw(1500)).await), "offline");
            // A set that arrives while the bus waits for a dead drive's answer is taken at
            // once: refused without waiting for the transaction; a queued one whose
            // max_age passes while the bus is held is refused as expired.
            h.state.borrow_mut().dead.insert(1);
            let killed = Instant::now();
            loop {
                sleep(Duration::from_millis(1)).await;
                let busy = h
                    .state
                    .borrow()
                    .log
                    .last()
                    .is_some_and(|(t, a, _)| *a == 1 && *t > killed);
                if busy {
                    break;
                }
            }
            let asked = Instant::now();
            assert_eq!(
                refused(&h.set(0, 1, SetValue::Raw(1500)).await),
                "not_writable"
            );
            assert!(asked.elapsed() < WIRE, "{:?}", asked.elapsed());
            let o = h
                .set_at(
                    1,
                    0,
                    SetValue::Raw(1500),
                    Instant::now(),
                    Duration::from_millis(50),
                )
                .await;
            assert_eq!(refused(&o), "expired");
            assert!(h.state.borrow().written.is_empty());
        })
        .await;
}

/// The page's requests (through [`crate::ui::drive::Remote`], the client the page's jobs use):
/// a read and a guarded write of a parameter the config does not poll run between the polls,
/// the polls keep their period, and a request for an offline drive is refused unsent.
#[tokio::test(start_paused = true)]
async fn the_pages_reads_and_writes_run_between_the_polls_and_never_reach_an_offline_drive() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let h = start(&plant);
            sleep(Duration::from_secs(1)).await;
            let max_age = Duration::from_secs(5);
            let mut remote = crate::ui::drive::Remote::connect(h.asks.clone(), 1, max_age)
                .await
                .unwrap();
            assert_eq!(remote.family(), drive_profile::Family::Movidrive);
            // P131 is not in the config: the page reads and writes it all the same.
            let p131 = drive_client::target::Target::of(
                drive_profile::family::lookup(drive_profile::Family::Movidrive, "P131").unwrap(),
            );
            h.state.borrow_mut().values.insert((2, p131.index), 4000);
            assert_eq!(remote.read(&p131).await.unwrap(), 4000);
            let ask = crate::ui::drive::WriteAsk {
                key: crate::ui::drive::key_of(&p131),
                value: "2.5".into(),
                eeprom: false,
                confirm: false,
            };
            let before = h.values(0, 0).len();
            let v = crate::ui::drive::write(&mut remote, &ask).await;
            assert_eq!(v["outcome"], "written", "{v}");
            assert_eq!(v["payload"]["raw"], 2500, "{v}");
            assert!(
                h.state
                    .borrow()
                    .written
                    .contains(&(2, p131.index, 2500, Persistence::Volatile)),
                "written to RAM at address 2"
            );
            // Out of range: refused by the guard, nothing sent.
            let writes = h.state.borrow().written.len();
            let far = crate::ui::drive::WriteAsk {
                value: "99999".into(),
                ..ask.clone()
            };
            let v = crate::ui::drive::write(&mut remote, &far).await;
            assert_eq!(
                (v["outcome"].as_str(), v["reason"].as_str()),
                (Some("refused"), Some("range")),
                "{v}"
            );
            assert_eq!(h.state.borrow().written.len(), writes, "nothing sent");
            // The polls of drive 0 went on at their 100 ms meanwhile.
            sleep(Duration::from_secs(1)).await;
            let polls = h.values(0, 0);
            assert!(polls.len() >= before + 9, "{} then {}", before, polls.len());
            for w in polls.windows(2).skip(before) {
                assert!(
                    w[1].0 - w[0].0 <= Duration::from_millis(130),
                    "{:?}",
                    w[1].0 - w[0].0
                );
            }
            // An offline drive: refused at once, never sent.
            h.state.borrow_mut().dead.insert(2);
            sleep(Duration::from_secs(2)).await;
            let sent = h.state.borrow().log.len();
            let started = Instant::now();
            let e = remote.read(&p131).await.unwrap_err();
            assert!(matches!(e, ClientError::Request(_)), "{e:?}");
            assert!(e.to_string().contains("does not answer"), "{e}");
            assert!(started.elapsed() < Duration::from_millis(50));
            let to_2_after = h.state.borrow().log[sent..]
                .iter()
                .filter(|(_, a, op)| *a == 2 && *op == crate::bus::Op::Read)
                .count();
            assert!(
                to_2_after <= 1,
                "at most the back-off's probe: {to_2_after}"
            );
        })
        .await;
}

/// A page that goes away during a backup (its answer's reader dropped) stops the backup before
/// its next transaction: the bus is not kept busy for a page nobody reads.
#[tokio::test(start_paused = true)]
async fn a_backup_stops_at_the_next_transaction_when_its_page_goes_away() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = three();
            let h = start(&plant);
            sleep(Duration::from_secs(1)).await;
            let remote =
                crate::ui::drive::Remote::connect(h.asks.clone(), 1, Duration::from_secs(5))
                    .await
                    .unwrap();
            let (lines, mut rx) = crate::ui::drive::Lines::new();
            let job = tokio::task::spawn_local(async move {
                let mut remote = remote;
                crate::ui::drive::backup(&mut remote, lines).await;
            });
            // A few values, then the page is gone.
            for _ in 0..6 {
                rx.recv().await.unwrap();
            }
            drop(rx);
            let gone = Instant::now();
            let reads_after = || {
                h.state
                    .borrow()
                    .log
                    .iter()
                    .filter(|(at, a, op)| *at >= gone && *a == 2 && *op == crate::bus::Op::Read)
                    .count()
            };
            tokio::time::timeout(Duration::from_secs(5), job)
                .await
                .expect("the job ends")
                .unwrap();
            sleep(Duration::from_secs(3)).await;
            // The drive's own polls go on: P130 every 100 ms, "fixed" and the status every
            // second (12 a second); of the backup, at most the read under way.
            let secs = gone.elapsed().as_secs_f64();
            let polls = (12.0 * secs).ceil() as usize + 2;
            assert!(
                reads_after() <= polls + 1,
                "{} reads in {secs} s after the page went away (polls: {polls})",
                reads_after()
            );
            let rows = drive_client::backup::rows(drive_profile::Family::Movidrive).len();
            assert!(rows > 100, "a whole backup would have taken {rows} reads");
        })
        .await;
}

/// Two drives with process data every 50 ms; only the first lets the page drive it.
fn page_plant() -> Plant {
    let t = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://127.0.0.1:1883\"\nmetrics = \"off\"\n\
             [[bus]]\nname = \"line1\"\nprotocol = \"movilink\"\nsimulate = true\n\
             status_period = \"1s\"\n\
             [[bus.drive]]\nname = \"belt\"\naddress = 1\n\
             [bus.drive.process_data]\nperiod = \"50ms\"\nout = [0x0102, 7]\npage_control = true\n\
             [[bus.drive]]\nname = \"fan\"\naddress = 2\n\
             [bus.drive.process_data]\nperiod = \"50ms\"\nout = [0x0102, 7]\n";
    match Plant::parse(t, "test") {
        Ok(p) => p,
        Err(e) => panic!("test config: {e}"),
    }
}

fn who(user: &str) -> crate::ui::auth::Who {
    crate::ui::auth::Who {
        user: user.to_owned(),
        role: crate::ui::auth::Role::Operator,
    }
}

impl Harness {
    async fn control(&self, drive: DriveIx, op: ControlOp) -> Result<Answer, ClientError> {
        let (reply, rx) = oneshot::channel();
        let ask = Ask {
            drive,
            op: AskOp::Control(op),
            received: Instant::now(),
            max_age: Duration::from_secs(5),
            reply,
        };
        self.asks.send(ask).await.unwrap();
        rx.await.unwrap()
    }

    /// Take `drive` for `user`: the lease's number and its receiver.
    async fn take(
        &self,
        drive: DriveIx,
        user: &str,
    ) -> Result<(u64, tokio::sync::watch::Receiver<Value>), ClientError> {
        let (tx, rx) = tokio::sync::watch::channel(Value::Null);
        let op = ControlOp::Take {
            who: who(user),
            lease: Arc::new(tx),
        };
        match self.control(drive, op).await? {
            Answer::Lease(n) => Ok((n, rx)),
            other => panic!("not a lease: {other:?}"),
        }
    }

    /// The words sent to `address` since `t`, each with its time.
    fn sent_since(&self, address: u8, t: Instant) -> Vec<(Instant, Vec<u16>)> {
        self.state
            .borrow()
            .exchanged
            .iter()
            .filter(|(at, a, _)| *a == address && *at >= t)
            .map(|(at, _, w)| (*at, w.clone()))
            .collect()
    }
}

use crate::model::{ControlOp, PageCommand};

/// Enable: the cycles after it carry the enable and the setpoint, and the command is answered
/// after the cycle that sent it; the lease dropped: the stop goes out at the next cycle (within
/// one period), then the config's `out` again.
#[tokio::test(start_paused = true)]
async fn the_page_drives_with_the_enable_and_setpoint_and_a_lost_lease_stops_within_a_cycle() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = page_plant();
            let h = start(&plant);
            sleep(Duration::from_millis(300)).await;
            assert!(
                h.sent_since(1, h.t0)
                    .iter()
                    .all(|(_, w)| w == &vec![0x0102, 7]),
                "the config's out until the page drives it"
            );
            let (lease, mut rx) = h.take(0, "alice").await.unwrap();
            let word = control::setpoint_word(drive_profile::Family::Movidrive, "300").unwrap();
            assert_eq!(word, 1500, "300 1/min at 0.2 1/min per digit");
            let asked = Instant::now();
            let answer = h
                .control(
                    0,
                    ControlOp::Command {
                        lease,
                        command: PageCommand::Enable { word },
                    },
                )
                .await
                .unwrap();
            let Answer::Text(text) = answer else {
                panic!("{answer:?}")
            };
            assert!(text.contains("enable at 300.0 1/min"), "{text}");
            let after = h.sent_since(1, asked);
            assert_eq!(after.last().map(|(_, w)| w.clone()), Some(vec![6, 1500]));
            assert!(
                Instant::now() - asked <= Duration::from_millis(60),
                "answered after one cycle"
            );
            let answered = Instant::now();
            sleep(Duration::from_millis(200)).await;
            assert!(
                h.sent_since(1, answered)
                    .iter()
                    .all(|(_, w)| w == &vec![6, 1500])
            );
            // The lease hears each cycle's state.
            assert!(rx.has_changed().unwrap());
            let v = rx.borrow_and_update().clone();
            assert_eq!(v["command"], "enable");
            assert_eq!(v["sent"], json!([6, 1500]));
            // The other drive never got the page's words.
            assert!(
                h.sent_since(2, h.t0)
                    .iter()
                    .all(|(_, w)| w == &vec![0x0102, 7])
            );
            let dropped = Instant::now();
            drop(rx);
            sleep(Duration::from_millis(300)).await;
            let after = h.sent_since(1, dropped);
            let (first, stop) = after.first().cloned().unwrap();
            assert_eq!(
                stop,
                vec![2, 0],
                "the stop is the first cycle after the lease ended"
            );
            assert!(
                first - dropped <= Duration::from_millis(50),
                "within one period"
            );
            assert!(after.len() > 2);
            assert!(
                after.iter().skip(1).all(|(_, w)| w == &vec![0x0102, 7]),
                "then the config's out again: {after:?}"
            );
            // The action log says the lost page stopped it.
            assert!(
                crate::ui::auth::actions()
                    .iter()
                    .any(|a| a.user == "alice" && a.action.contains("page lost: stop drive belt")),
            );
            // The drive is free again: a command of the old lease is refused.
            let late = h
                .control(
                    0,
                    ControlOp::Command {
                        lease,
                        command: PageCommand::Stop,
                    },
                )
                .await;
            assert!(
                matches!(late, Err(ClientError::Request(ref m)) if m.contains("lease ended")),
                "{late:?}"
            );
            assert!(h.take(0, "bob").await.is_ok());
        })
        .await;
}

/// One page drives a drive at a time: a second is refused and told who drives it; a drive
/// the config does not give the page is refused with what the config needs.
#[tokio::test(start_paused = true)]
async fn a_second_page_and_a_drive_without_page_control_are_refused() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = page_plant();
            let h = start(&plant);
            sleep(Duration::from_millis(200)).await;
            let (lease, _rx) = h.take(0, "alice").await.unwrap();
            let second = h.take(0, "bob").await;
            match second {
                Err(ClientError::Request(m)) => {
                    assert!(m.contains("driven from another page by alice"), "{m}")
                }
                other => panic!("{other:?}"),
            }
            // Another lease number does not command it either.
            let (tx, _keep) = tokio::sync::watch::channel(Value::Null);
            drop(tx);
            let wrong = h
                .control(
                    0,
                    ControlOp::Command {
                        lease: u64::MAX,
                        command: PageCommand::Stop,
                    },
                )
                .await;
            assert!(
                matches!(wrong, Err(ClientError::Request(ref m)) if m.contains("alice does")),
                "{wrong:?}"
            );
            match h.take(1, "alice").await {
                Err(ClientError::Request(m)) => assert!(m.contains("page_control = true"), "{m}"),
                other => panic!("{other:?}"),
            }
            sleep(Duration::from_millis(200)).await;
            assert!(
                h.sent_since(2, h.t0)
                    .iter()
                    .all(|(_, w)| w == &vec![0x0102, 7])
            );
            assert!(
                h.sent_since(1, h.t0)
                    .iter()
                    .all(|(_, w)| w == &vec![0x0102, 7]),
                "nothing commanded yet"
            );
            // The page's stop: the stop words from the next cycle on, the lease still held.
            let before_stop = Instant::now();
            let stopped = h
                .control(
                    0,
                    ControlOp::Command {
                        lease,
                        command: PageCommand::Stop,
                    },
                )
                .await;
            assert!(
                matches!(stopped, Ok(Answer::Text(ref t)) if t.contains("sent stop")),
                "{stopped:?}"
            );
            sleep(Duration::from_millis(200)).await;
            let after = h.sent_since(1, before_stop);
            assert_eq!(after.last().map(|(_, w)| w.clone()), Some(vec![2, 0]));
            assert!(h.take(0, "bob").await.is_err(), "alice still holds it");
        })
        .await;
}

/// Setpoints past the family's limits are refused with the reason before anything is sent.
#[test]
fn setpoints_are_checked_against_the_family_words() {
    use drive_profile::Family;
    assert_eq!(
        control::setpoint_word(Family::Movidrive, "-1000"),
        Ok((-5000i16) as u16)
    );
    assert_eq!(
        control::setpoint_word(Family::Movidrive, "6553.4"),
        Ok(32767)
    );
    let past = control::setpoint_word(Family::Movidrive, "7000").unwrap_err();
    assert!(
        past.contains("past what the speed setpoint word holds"),
        "{past}"
    );
    let fine = control::setpoint_word(Family::Movidrive, "300.1").unwrap_err();
    assert!(
        fine.contains("nearest is 300.0") || fine.contains("nearest is 300.2"),
        "{fine}"
    );
    assert!(control::setpoint_word(Family::Movidrive, "fast").is_err());
    assert_eq!(control::setpoint_word(Family::Nord, "50"), Ok(0x2000));
    assert!(
        control::setpoint_word(Family::Nord, "250")
            .unwrap_err()
            .contains("−200 %")
    );
    assert!(
        control::setpoint_word(Family::Bonfiglioli, "10")
            .unwrap_err()
            .contains("no process data")
    );
}

/// The families' words: SEW as P870–P872 lay them out (the factory's PO1 control word 1, PO2
/// speed), NORD STW/SW1 stepping toward "operation enabled".
#[test]
fn the_families_words_follow_the_drive_s_layout() {
    use crate::families::access::{nord_control_words, sew_control_words, sew_layout};
    let factory = sew_layout(&[9, 1, 0]);
    let out = [0x0102, 7, 9];
    assert_eq!(
        sew_control_words(&factory, &out, PageCommand::Enable { word: 1500 }),
        Ok(vec![0x0106, 1500, 9])
    );
    assert_eq!(
        sew_control_words(&factory, &out, PageCommand::Stop),
        Ok(vec![0x0102, 0, 9])
    );
    let no_speed = sew_layout(&[9, 0, 0]);
    assert!(
        sew_control_words(&no_speed, &out, PageCommand::Enable { word: 5 })
            .unwrap_err()
            .contains("speed setpoint")
    );
    assert!(
        sew_control_words(&sew_layout(&[1, 0]), &out, PageCommand::Stop)
            .unwrap_err()
            .contains("control word")
    );
    // NORD from "switch on disabled" (ZSW 0x0040): shutdown first, SW1 the setpoint.
    let w = nord_control_words(
        &[0, 0],
        PageCommand::Enable { word: 0x2000 },
        &[],
        &[0x0040],
    )
    .unwrap();
    assert_eq!(w, vec![0x047E, 0x2000]);
    assert_eq!(
        nord_control_words(&[0, 0], PageCommand::Stop, &[], &[]),
        Ok(vec![0x047E, 0])
    );
    assert!(nord_control_words(&[0], PageCommand::Enable { word: 1 }, &[], &[]).is_err());
}

/// A lease whose page is silent (a connection lost without a word keeps its TCP stream open
/// for minutes) ends after LEASE_SILENCE: the stop goes out; a page that says it is there
/// keeps driving.
#[tokio::test(start_paused = true)]
async fn a_silent_lease_ends_and_its_drive_is_stopped() {
    tokio::task::LocalSet::new()
        .run_until(async {
            let plant = page_plant();
            let h = start(&plant);
            sleep(Duration::from_millis(200)).await;
            let (lease, _rx) = h.take(0, "carol").await.unwrap();
            let enable = PageCommand::Enable { word: 500 };
            h.control(
                0,
                ControlOp::Command {
                    lease,
                    command: enable,
                },
            )
            .await
            .unwrap();
            // Heard of every second for twice the silence: it keeps driving.
            for _ in 0..10 {
                sleep(Duration::from_secs(1)).await;
                assert!(matches!(
                    h.control(0, ControlOp::Alive { lease }).await,
                    Ok(Answer::Done)
                ));
            }
            let quiet = Instant::now();
            let sent = h.sent_since(1, h.t0);
            assert_eq!(sent.last().map(|(_, w)| w.clone()), Some(vec![6, 500]));
            sleep(crate::model::LEASE_SILENCE + Duration::from_millis(200)).await;
            let after = h.sent_since(1, quiet);
            let stop = after
                .iter()
                .position(|(_, w)| w == &vec![2, 0])
                .expect("the stop goes out");
            let (at, _) = after[stop];
            assert!(at - quiet <= crate::model::LEASE_SILENCE + Duration::from_millis(60));
            assert!(after[..stop].iter().all(|(_, w)| w == &vec![6, 500]));
            assert!(after[stop + 1..].iter().all(|(_, w)| w == &vec![0x0102, 7]));
            assert!(h.control(0, ControlOp::Alive { lease }).await.is_err());
        })
        .await;
}
