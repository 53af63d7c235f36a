//! MOVILINK fault-injection campaign over the in-memory link (8E1 at 9600 baud, wire timing,
//! paused clock): a `movilink::Master` and a `movilink::Slave` exchange reads, writes and
//! process data while characters are dropped, inserted and bit-flipped on the wire.
//!
//! * `single_faults_are_always_caught`: at most one fault per telegram (one flipped bit of one
//!   11-bit character frame, one inserted or one dropped character) at ≈ 1 % of the
//!   characters, both directions, ≥ 100 000 transactions: no wrong value is ever accepted,
//!   every faulted telegram is rejected, every clean one accepted.
//! * `random_faults_match_theory`: drops, inserts and 1-, 2- and 3-bit flips at 1 % per
//!   character each (so several faults per telegram happen): the measured rate of undetected
//!   errors against the theoretical rate of even parity + XOR block check.
//! * `theory_matches_bit_level_monte_carlo`: the formula against a bit-level simulation that
//!   does not use the link.
//!
//! Figures and method: `docs/protocols/movilink-fault-injection.md`. Run with
//! `cargo test -p drivebus-tests movilink_faults -- --nocapture` to see them;
//! `MOVILINK_FAULT_SCALE=10` multiplies the number of transactions.

use std::collections::BTreeMap;
use std::time::Instant as WallClock;

use drive_transport::link::{Fault, FaultConfig};
use drivebus_tests::movilink_bus::{
    DirStats, LinkBus, Rng, Side, drive_address, input_word, read_value, write_value,
};
use movilink::{
    Address, AddressFilter, Direction, LineTiming, MasterEvent, ParamChannel, PduType, Receiver,
    RxChar, RxEvent, Telegram, TelegramFraming, codec,
};

/// Transactions of a campaign, scaled by `MOVILINK_FAULT_SCALE` (default 1).
fn scaled(n: u64) -> u64 {
    let scale = std::env::var("MOVILINK_FAULT_SCALE")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(1.0);
    ((n as f64) * scale).max(1.0) as u64
}

/// What the master should report for a transaction.
#[derive(Debug, Clone, Copy)]
enum Expect {
    /// The parameter service's data.
    Param(u32),
    /// No parameter service.
    None,
}

/// A random transaction of the campaign mix: acyclic and cyclic parameter reads and writes,
/// with and without process data, and pure process data exchanges.
fn random_transaction(rng: &mut Rng) -> (Telegram, Expect, Vec<u16>) {
    let index = 8300 + rng.below(700) as u16;
    let po: Vec<u16> = (0..3).map(|_| rng.next_u64() as u16).collect();
    let read = (
        ParamChannel::read(index),
        Expect::Param(read_value(index, 0)),
    );
    let w = write_value(index, rng.next_u64() as u16);
    let write = (ParamChannel::write_volatile(index, w), Expect::Param(w));
    let (pdu, param) = match rng.below(10) {
        0 | 1 => (PduType::PARAM_0PD_ACYCLIC, Some(read)),
        2 => (PduType::PARAM_0PD_ACYCLIC, Some(write)),
        3 => (PduType::PARAM_3PD_ACYCLIC, Some(read)),
        4 => (PduType::PARAM_3PD, Some(read)),
        5 => (PduType::PARAM_3PD, Some(write)),
        6 => (PduType::PARAM_1PD_ACYCLIC, Some(write)),
        7 => (PduType::PD3, None),
        8 => (PduType::PD1_ACYCLIC, None),
        _ => (PduType::PARAM_2PD, Some(read)),
    };
    let po = po[..pdu.pd_words()].to_vec();
    let mut t = Telegram::request(drive_address(), pdu).with_process_data(&po);
    let expect = match param {
        Some((p, e)) => {
            t = t.with_param(p);
            e
        }
        None => Expect::None,
    };
    (t, expect, po)
}

/// Outcome counts of the transactions, as the user of the master sees them.
#[derive(Debug, Default)]
struct Outcomes {
    transactions: u64,
    succeeded: u64,
    /// Succeeded after at least one failed attempt.
    retried: u64,
    /// No valid answer after all attempts (`Timeout`, `ParamNotExecuted`).
    lost: u64,
    /// Transactions that reported a value to the user that differs from the drive's
    /// (parameter data or process input words).
    wrong_values: u64,
    /// Transactions without any fault on the wire that did not succeed.
    clean_failed: u64,
    /// Cyclic services whose first exchange found the drive's handshake bit other than the
    /// master remembered (after a cyclic transaction was lost): one extra exchange each.
    handshake_resyncs: u64,
}

/// Checks the master's events of one transaction against the known answers.
fn judge(bus: &LinkBus, expect: Expect, po: &[u16], clean: bool, out: &mut Outcomes) {
    out.transactions += 1;
    let mut done = false;
    let mut wrong = false;
    let mut failed_attempts = 0;
    for e in &bus.events {
        match e {
            MasterEvent::Response { telegram } => {
                let pi = telegram.process_data();
                if pi.len() != po.len()
                    || pi.iter().enumerate().any(|(j, w)| *w != input_word(po, j))
                {
                    wrong = true;
                }
                if matches!(expect, Expect::None) {
                    done = true;
                }
            }
            MasterEvent::ParamDone(result) => {
                match (expect, result) {
                    (Expect::Param(v), Ok(got)) if v == *got => {}
                    _ => wrong = true,
                }
                done = true;
            }
            MasterEvent::Rejected(movilink::RejectReason::ParamMismatch) => {
                out.handshake_resyncs += 1;
            }
            MasterEvent::Rejected(_) => failed_attempts += 1,
            MasterEvent::Timeout { .. } | MasterEvent::ParamNotExecuted { .. } => out.lost += 1,
            _ => {}
        }
    }
    if done {
        out.succeeded += 1;
    }
    out.wrong_values += u64::from(wrong);
    let attempts_failed = failed_attempts > 0 || !done;
    if done && attempts_failed {
        out.retried += 1;
    }
    if clean && (failed_attempts > 0 || !done) {
        out.clean_failed += 1;
    }
}

fn faulted_total(bus: &LinkBus) -> u64 {
    bus.stats.iter().map(|s| s.faulted).sum()
}

fn print_dir(name: &str, s: &DirStats) {
    eprintln!(
        "  {name}: sent {}, chars {}, faulted {} {:?}",
        s.sent, s.chars, s.faulted, s.faulted_by_kind
    );
    eprintln!(
        "    rejected {} {:?}, lost {}, undetected {}, caught by master's checks {}, \
         faulted but accepted unchanged {}, clean accepted {}, clean failed {}, \
         refused clean {:?}, extra events {}",
        s.rejected_total(),
        s.rejected,
        s.lost,
        s.undetected,
        s.caught_by_master,
        s.faulted_accepted_equal,
        s.clean_accepted,
        s.clean_failed,
        s.refused_by_master,
        s.extra_events
    );
}

/// Single faults: at most one per telegram, at ≈ 1 % of the characters.
#[tokio::test(start_paused = true)]
async fn single_faults_are_always_caught() {
    let wall = WallClock::now();
    let transactions = scaled(100_000);
    let mut plan_rng = Rng::new(0x51A6_1E00_FA17);
    let plan = Box::new(move |_side: Side, bytes: &[u8]| {
        // P(telegram faulted) = 1 − 0.99^n: 1 % of the characters, one fault per telegram.
        if !plan_rng.chance(1.0 - 0.99f64.powi(bytes.len() as i32)) {
            return Vec::new();
        }
        let pos = plan_rng.below(bytes.len() as u64) as usize;
        let fault = match plan_rng.below(3) {
            // Any one of the 11 frame bits: start, 8 data, parity, stop.
            0 => Fault::Flip(1 << plan_rng.below(11)),
            1 => Fault::Insert(plan_rng.next_u64() as u8),
            _ => Fault::Drop,
        };
        vec![(pos, fault)]
    });
    let mut bus = LinkBus::new(FaultConfig::none(), Some(plan));
    let mut rng = Rng::new(0x7EA5_AC71_0000);
    let mut out = Outcomes::default();
    for _ in 0..transactions {
        let (req, expect, po) = random_transaction(&mut rng);
        let before = faulted_total(&bus);
        bus.transact(req).await;
        let clean = faulted_total(&bus) == before;
        judge(&bus, expect, &po, clean, &mut out);
    }
    // Let the last telegrams be judged, then close the books.
    bus.finish_all();
    let [req, resp] = &bus.stats;
    eprintln!(
        "single-fault campaign: {} transactions in {:.1} s wall, {:.0} s simulated, {} steps",
        out.transactions,
        wall.elapsed().as_secs_f64(),
        bus.now().as_micros() as f64 / 1e6,
        bus.steps
    );
    eprintln!("  outcomes: {out:?}");
    print_dir("requests (master → drive)", req);
    print_dir("responses (drive → master)", resp);
    let backend = bus.slave.backend();
    eprintln!(
        "  drive: reads {}, writes {} (corrupted {}), pd exchanges {}; late transmissions {}",
        backend.reads,
        backend.writes,
        backend.bad_writes,
        backend.pd_exchanges,
        bus.late_transmissions
    );

    // No wrong value, anywhere.
    assert_eq!(out.wrong_values, 0, "wrong values reported to the user");
    assert_eq!(
        backend.bad_writes, 0,
        "corrupted writes executed by the drive"
    );
    for (name, s) in [("requests", req), ("responses", resp)] {
        assert_eq!(s.undetected, 0, "{name}: undetected errors");
        assert_eq!(s.caught_by_master, 0, "{name}: errors past the wire checks");
        // Every faulted telegram was rejected by a wire check (none lost without a trace),
        // every clean one accepted: the receivers resynchronise on the very next telegram.
        assert_eq!(
            s.faulted,
            s.rejected_total() + s.lost,
            "{name}: faults add up"
        );
        assert_eq!(s.lost, 0, "{name}: faulted telegrams without a rejection");
        assert_eq!(s.clean_failed, 0, "{name}: clean telegrams not accepted");
        assert_eq!(s.extra_events, 0, "{name}: events without a telegram");
        assert_eq!(s.faulted_accepted_equal, 0, "{name}");
        assert_eq!(
            s.clean_accepted + s.faulted,
            s.sent,
            "{name}: telegrams add up"
        );
        assert!(s.faulted > 0);
    }
    // Clean responses refused by the master: only the handshake resynchronisation after a
    // lost cyclic transaction (the drive repeats the previous answer once).
    let refused: u64 = resp.refused_by_master.values().sum();
    assert_eq!(
        refused,
        resp.refused_by_master
            .get("parameter channel mismatch")
            .copied()
            .unwrap_or(0)
    );
    assert_eq!(refused, out.handshake_resyncs);
    assert!(out.handshake_resyncs <= out.lost);
    // Faulted responses cost a retry; a transaction without faults never fails.
    assert_eq!(out.clean_failed, 0);
    assert_eq!(out.succeeded + out.lost, out.transactions);
    assert_eq!(bus.late_transmissions, 0);
    // ≈ 1 % of the characters faulted.
    let chars = (req.chars + resp.chars) as f64;
    let rate = (req.faulted + resp.faulted) as f64 / chars;
    assert!((0.008..0.011).contains(&rate), "fault rate {rate}");
    assert!(out.transactions >= 100_000 || std::env::var("MOVILINK_FAULT_SCALE").is_ok());
}

// ---------------------------------------------------------------------------------------------
// Theory: even parity per character + XOR block check character.

/// Random fault probabilities per character (the link's `FaultConfig` model).
#[derive(Debug, Clone, Copy)]
struct Model {
    drop: f64,
    insert: f64,
    flip: f64,
    flip_bits: u32,
}

/// Per flipped character (k distinct positions of the 11-bit frame, uniformly): the
/// probability `w[e]` that the UART flags nothing (start and stop bits intact, an even number
/// of flipped data + parity bits) and the data bits change by the pattern `e`.
fn pass_weights(k: u32) -> [f64; 256] {
    let mut w = [0.0; 256];
    let subsets: Vec<u16> = (0u16..1 << 11).filter(|m| m.count_ones() == k).collect();
    let each = 1.0 / subsets.len() as f64;
    for m in subsets {
        let framing = m & 1 != 0 || m & (1 << 10) != 0;
        let parity_ok = (m >> 1 & 0x1FF).count_ones() % 2 == 0;
        if !framing && parity_ok {
            w[usize::from((m >> 1) as u8)] += each;
        }
    }
    w
}

fn binomial(n: u64, k: u64) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// Probability that a telegram of `n` characters is accepted with wrong content (parity, XOR
/// BCC, and the header checks: the start character, address and PDU type must arrive intact;
/// a header byte that changes is caught by the start-character, address, type or length
/// check). Two terms, exact up to third-order terms in the fault probabilities:
///
/// * no drops or inserts: `m ≥ 2` flipped characters in the `n − 3` characters after the
///   header, each passing the UART checks, whose data-bit error patterns XOR to zero
///   (`Q_m = 2⁻⁸ Σ_s ŵ(s)^m`, the XOR convolution via the Walsh–Hadamard transform);
/// * one drop after the header and one insert (after character 2 or later), so the length is
///   right: the received XOR is off by `dropped ^ inserted`, and the inserted byte is random:
///   the BCC passes with probability 1/256, if no flipped character is flagged.
///
/// A single drop or insert is always caught: telegram lengths are even, so a telegram one
/// character short or long never has the length its (intact) header implies (gap or trailing
/// character check), and shifted headers fail the header checks.
fn escape_probability(n: usize, m: &Model) -> f64 {
    let w = pass_weights(m.flip_bits);
    let pass: f64 = w.iter().sum();
    let hat: Vec<f64> = (0..256u32)
        .map(|s| {
            (0..256u32)
                .map(|e| {
                    let sign = if (s & e).count_ones() % 2 == 0 {
                        1.0
                    } else {
                        -1.0
                    };
                    w[e as usize] * sign
                })
                .sum()
        })
        .collect();
    let q = |k: i32| hat.iter().map(|h| h.powi(k)).sum::<f64>() / 256.0;
    let body = n as u64 - 3;
    let (pd, pi, pf) = (m.drop, m.insert, m.flip);
    let no_shift = ((1.0 - pd) * (1.0 - pi)).powi(n as i32);
    let flips: f64 = (2..=body)
        .map(|k| {
            binomial(body, k) * pf.powi(k as i32) * (1.0 - pf).powi((body - k) as i32) * q(k as i32)
        })
        .sum::<f64>()
        * (1.0 - pf).powi(3);
    let one_drop = (n - 3) as f64 * pd * (1.0 - pd).powi(n as i32 - 1);
    let one_insert = (n - 2) as f64 * pi * (1.0 - pi).powi(n as i32 - 1);
    let unflagged = (1.0 - pf).powi(3) * (1.0 - pf * (1.0 - pass)).powi(n as i32 - 4);
    no_shift * flips + one_drop * one_insert * unflagged / 256.0
}

/// The parity + XOR-BCC escape probability alone (no header checks), for the doc: flips only.
fn escape_probability_parity_bcc_flips(n: usize, m: &Model) -> f64 {
    let w = pass_weights(m.flip_bits);
    let hat: Vec<f64> = (0..256u32)
        .map(|s| {
            (0..256u32)
                .map(|e| {
                    let sign = if (s & e).count_ones() % 2 == 0 {
                        1.0
                    } else {
                        -1.0
                    };
                    w[e as usize] * sign
                })
                .sum()
        })
        .collect();
    let q = |k: i32| hat.iter().map(|h| h.powi(k)).sum::<f64>() / 256.0;
    let pf = m.flip;
    (2..=n as u64)
        .map(|k| {
            binomial(n as u64, k)
                * pf.powi(k as i32)
                * (1.0 - pf).powi((n as u64 - k) as i32)
                * q(k as i32)
        })
        .sum()
}

/// Whether `observed` is a plausible draw of a Poisson variable with mean `lambda`: both tail
/// probabilities above `alpha`.
fn poisson_consistent(observed: u64, lambda: f64, alpha: f64) -> (bool, f64, f64) {
    let mut pmf = (-lambda).exp();
    let mut below = 0.0; // P(X < observed)
    for k in 0..observed {
        below += pmf;
        pmf *= lambda / (k + 1) as f64;
    }
    let at_most = below + pmf; // P(X ≤ observed)
    let at_least = 1.0 - below; // P(X ≥ observed)
    (at_most > alpha && at_least > alpha, at_most, at_least)
}

/// Expected escapes for the telegrams sent, by length.
fn expected_escapes(s: &DirStats, m: &Model) -> f64 {
    s.lengths
        .iter()
        .map(|(n, (sent, _))| *sent as f64 * escape_probability(*n, m))
        .sum()
}

/// Random faults at 1 % per character each (drop, insert, flip of 1, 2 or 3 bits).
#[tokio::test(start_paused = true)]
async fn random_faults_match_theory() {
    let wall = WallClock::now();
    let per_run = scaled(100_000);
    let mut total_observed = 0;
    let mut total_expected = 0.0;
    let mut summary = BTreeMap::new();
    for flip_bits in [1u32, 2, 3] {
        let model = Model {
            drop: 0.01,
            insert: 0.01,
            flip: 0.01,
            flip_bits,
        };
        let faults = FaultConfig {
            seed: 0xFA_0172 + u64::from(flip_bits),
            drop: model.drop,
            insert: model.insert,
            flip: model.flip,
            flip_bits,
            ..FaultConfig::none()
        };
        let mut bus = LinkBus::new(faults, None);
        let mut rng = Rng::new(0x7A2D_0000 + u64::from(flip_bits));
        let mut out = Outcomes::default();
        for _ in 0..per_run {
            let (req, expect, po) = random_transaction(&mut rng);
            let before = faulted_total(&bus);
            bus.transact(req).await;
            let clean = faulted_total(&bus) == before;
            judge(&bus, expect, &po, clean, &mut out);
        }
        bus.finish_all();
        let backend = bus.slave.backend();
        eprintln!(
            "random campaign, 1 % drop + 1 % insert + 1 % flip of {flip_bits} bit(s): {} \
             transactions, {:.1} s wall",
            out.transactions,
            wall.elapsed().as_secs_f64()
        );
        eprintln!(
            "  outcomes: {out:?}; corrupted writes executed {}",
            backend.bad_writes
        );
        let mut observed = 0;
        let mut expected = 0.0;
        let mut faulted = 0;
        for (name, s) in [("requests", &bus.stats[0]), ("responses", &bus.stats[1])] {
            print_dir(name, s);
            let lambda = expected_escapes(s, &model);
            let escapes = s.undetected + s.caught_by_master;
            eprintln!(
                "    {name}: wire-check escapes {escapes} (undetected {} + caught by the master's \
                 application checks {}), theory {lambda:.2}; per faulted telegram {:.2e} \
                 (theory {:.2e})",
                s.undetected,
                s.caught_by_master,
                escapes as f64 / s.faulted as f64,
                lambda / s.faulted as f64
            );
            observed += escapes;
            expected += lambda;
            faulted += s.faulted;
            // Nothing else may go wrong: clean telegrams are always accepted.
            assert_eq!(s.clean_failed, 0, "{name}");
            assert_eq!(s.extra_events, 0, "{name}");
        }
        let (ok, lo, hi) = poisson_consistent(observed, expected, 1e-3);
        eprintln!(
            "  escapes {observed} vs theory {expected:.2} (P(X≤obs) {lo:.3}, P(X≥obs) {hi:.3}); \
             wrong values reported {} = {:.2e} per transaction, {:.2e} per faulted telegram",
            out.wrong_values,
            out.wrong_values as f64 / out.transactions as f64,
            out.wrong_values as f64 / faulted as f64
        );
        assert!(
            ok,
            "flip_bits {flip_bits}: {observed} escapes, theory {expected:.2}"
        );
        assert_eq!(bus.late_transmissions, 0);
        total_observed += observed;
        total_expected += expected;
        summary.insert(flip_bits, (observed, expected, out.wrong_values, faulted));
    }
    let (ok, lo, hi) = poisson_consistent(total_observed, total_expected, 1e-3);
    eprintln!(
        "random campaigns: escapes {total_observed} vs theory {total_expected:.2} \
         (P(X≤obs) {lo:.3}, P(X≥obs) {hi:.3}); by flip bits (observed, theory, wrong values, \
         faulted telegrams): {summary:?}"
    );
    assert!(ok);
}

// ---------------------------------------------------------------------------------------------
// Bit-level Monte-Carlo, independent of the link: the formula checked by simulation.

/// The 11-bit frame of `byte`: start 0, data LSB first, even parity, stop 1.
fn frame(byte: u8) -> u16 {
    let parity = u16::from(byte.count_ones() % 2 == 1);
    (u16::from(byte) << 1) | (parity << 9) | (1 << 10)
}

/// What a UART makes of a received frame: the data byte and whether it flags an error.
fn uart(frame: u16) -> (u8, bool) {
    let byte = (frame >> 1) as u8;
    let parity = frame >> 9 & 1;
    let ok = frame & 1 == 0
        && frame >> 10 & 1 == 1
        && (byte.count_ones() + u32::from(parity)).is_multiple_of(2);
    (byte, ok)
}

/// Sends `bytes` through the bit-level fault model into a receiver; true if the receiver
/// accepted a telegram that differs from the one sent.
fn simulate(bytes: &[u8], direction: Direction, m: &Model, rng: &mut Rng) -> bool {
    let filter = match direction {
        Direction::Request => AddressFilter::Slave {
            own: drive_address(),
            group: Address::NO_GROUP,
        },
        _ => AddressFilter::Master {
            expected: drive_address(),
        },
    };
    let mut rx = Receiver::new(TelegramFraming::new(
        direction,
        filter,
        LineTiming::MOVILINK,
    ));
    let sent = codec::decode(bytes).map(|(t, _)| t).ok();
    let mut t = 3440;
    let mut accepted = None;
    let mut deliver = |rx: &mut Receiver, f: u16, t: u64| {
        let (byte, ok) = uart(f);
        let time = movilink::Instant::from_micros(t);
        let c = if ok {
            RxChar::new(byte, time)
        } else {
            RxChar::with_error(byte, time, movilink::CharError::Parity)
        };
        if let Some(RxEvent::Frame(tg)) = rx.handle_char(c) {
            accepted = Some(tg);
        }
    };
    for b in bytes {
        t += 1146;
        let dropped = rng.chance(m.drop);
        if rng.chance(m.flip) && !dropped {
            let mut mask = 0u16;
            while mask.count_ones() < m.flip_bits {
                mask |= 1 << rng.below(11);
            }
            deliver(&mut rx, frame(*b) ^ mask, t);
        } else if !dropped {
            deliver(&mut rx, frame(*b), t);
        }
        if rng.chance(m.insert) {
            t += 1146;
            deliver(&mut rx, frame(rng.next_u64() as u8), t);
        }
    }
    if let Some(RxEvent::Frame(tg)) = rx.handle_timeout(movilink::Instant::from_micros(t + 3440)) {
        accepted = Some(tg);
    }
    accepted.is_some() && accepted != sent
}

#[test]
fn theory_matches_bit_level_monte_carlo() {
    let wall = WallClock::now();
    let trials = scaled(400_000);
    let mut rng = Rng::new(0x0B17_1E7E_1000);
    // Telegram lengths of the campaign mix, both directions.
    let mut summary = Vec::new();
    for flip_bits in [2u32, 3] {
        // A higher fault rate than the campaign makes escapes frequent enough to test the
        // formula with few trials; 2 % keeps the neglected higher-order terms small.
        let model = Model {
            drop: 0.02,
            insert: 0.02,
            flip: 0.02,
            flip_bits,
        };
        let by_len: Vec<f64> = (0..=18)
            .map(|n| {
                if n < 6 {
                    0.0
                } else {
                    escape_probability(n, &model)
                }
            })
            .collect();
        let mut observed = 0;
        let mut expected = 0.0;
        for i in 0..trials {
            let (req, _, _) = random_transaction(&mut rng);
            let mut t = req;
            if i % 2 == 1 {
                // A response of the same layout.
                t = Telegram::response(drive_address(), req.pdu_type())
                    .with_process_data(req.process_data());
                if let Some(p) = req.param() {
                    t = t.with_param(p.answer(Ok(rng.next_u64() as u32)));
                }
            }
            let mut buf = [0u8; 18];
            let n = codec::encode(&t, &mut buf).unwrap_or(0);
            expected += by_len[n];
            if simulate(&buf[..n], t.direction(), &model, &mut rng) {
                observed += 1;
            }
        }
        let (ok, lo, hi) = poisson_consistent(observed, expected, 1e-3);
        eprintln!(
            "monte-carlo, 2 % drop/insert/flip of {flip_bits} bits: {trials} telegrams, \
             escapes {observed} vs formula {expected:.1} (P(X≤obs) {lo:.3}, P(X≥obs) {hi:.3})"
        );
        summary.push((flip_bits, observed, expected));
        assert!(ok, "flip_bits {flip_bits}: {observed} vs {expected:.1}");
    }
    // For the doc: the rates of parity + XOR alone for flips, per telegram length.
    for n in [6usize, 12, 18] {
        let m = Model {
            drop: 0.0,
            insert: 0.0,
            flip: 0.01,
            flip_bits: 2,
        };
        eprintln!(
            "  n = {n}: 1 % two-bit flips, parity + XOR alone {:.3e}, with header checks {:.3e}; \
             1 % drop/insert/2-bit flip with header checks {:.3e}",
            escape_probability_parity_bcc_flips(n, &m),
            escape_probability(n, &m),
            escape_probability(
                n,
                &Model {
                    drop: 0.01,
                    insert: 0.01,
                    ..m
                }
            )
        );
    }
    eprintln!("  ({:.1} s wall)", wall.elapsed().as_secs_f64());
}
