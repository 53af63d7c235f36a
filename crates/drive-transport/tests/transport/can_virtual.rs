//! The virtual CAN bus: arbitration, frame times on the paused clock, overruns, faults, end.

use std::io;
use std::time::Duration;

use drive_core::can::{Bitrate, CanFrame, ExtendedId, StandardId};
use drive_core::rt::{recv_frame, send_frame};
use drive_transport::can::{BusConfig, BusFault, BusFaults, VirtualBus};
use tokio::time::{Instant, timeout};

fn std_frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

#[tokio::test(start_paused = true)]
async fn simultaneous_frames_go_in_identifier_order_back_to_back() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b, mut rx) = (bus.node(), bus.node(), bus.node());
    let high = std_frame(0x200, &[1, 2, 3]);
    let low = std_frame(0x100, &[0xFF; 8]);
    let start = Instant::now();
    // `a` (the higher identifier) asks first; `b` asks at the same instant and wins.
    let ta = tokio::spawn(async move { send_frame(&mut a, &high).await.map(|()| a) });
    let tb = tokio::spawn(async move { send_frame(&mut b, &low).await.map(|()| b) });
    let first = recv_frame(&mut rx).await.unwrap();
    let second = recv_frame(&mut rx).await.unwrap();
    assert_eq!(first.frame, low);
    assert_eq!(second.frame, high);
    let d_low = low.duration(Bitrate::K500);
    assert_eq!(first.at - start, d_low);
    // The second starts when the first ends: exactly one frame time later.
    assert_eq!(second.at - first.at, high.duration(Bitrate::K500));
    let _ = ta.await.unwrap().unwrap();
    let _ = tb.await.unwrap().unwrap();
}

#[tokio::test(start_paused = true)]
async fn an_8_byte_frame_at_500_kbit_takes_its_computed_bits() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b) = (bus.node(), bus.node());
    let frame = std_frame(0x10B, &[0x00, 0x06, 0x13, 0x88, 0x00, 0x00, 0x00, 0x00]);
    let bits = frame.bits();
    // 47 + 64 bits without stuffing, at most 135 with the worst case.
    assert!((111..=135).contains(&bits), "{bits}");
    let start = Instant::now();
    let (sent, got) = tokio::join!(send_frame(&mut a, &frame), recv_frame(&mut b));
    sent.unwrap();
    let got = got.unwrap();
    assert_eq!(got.at - start, Duration::from_micros(2 * u64::from(bits)));
    // The send completed only after the frame had left the wire.
    assert!(Instant::now() >= got.at);
}

#[tokio::test(start_paused = true)]
async fn standard_wins_over_extended_with_the_same_base_identifier() {
    let bus = VirtualBus::new(Bitrate::K250);
    let (mut a, mut b, mut rx) = (bus.node(), bus.node(), bus.node());
    let ext = CanFrame::data_frame(ExtendedId::new(0x100 << 18).unwrap(), &[1]).unwrap();
    let std = CanFrame::data_frame(StandardId::new(0x100).unwrap(), &[1]).unwrap();
    let remote = CanFrame::remote_frame(StandardId::new(0x100).unwrap(), 1).unwrap();
    let mut c = bus.node();
    let t1 = tokio::spawn(async move { send_frame(&mut a, &ext).await });
    let t2 = tokio::spawn(async move { send_frame(&mut c, &remote).await });
    let t3 = tokio::spawn(async move { send_frame(&mut b, &std).await });
    let order: Vec<CanFrame> = vec![
        recv_frame(&mut rx).await.unwrap().frame,
        recv_frame(&mut rx).await.unwrap().frame,
        recv_frame(&mut rx).await.unwrap().frame,
    ];
    // Data before remote (RTR), standard before extended (IDE/SRR).
    assert_eq!(order, vec![std, remote, ext]);
    for t in [t1, t2, t3] {
        t.await.unwrap().unwrap();
    }
}

#[tokio::test(start_paused = true)]
async fn frames_of_one_node_are_back_to_back_and_others_see_all() {
    let bus = VirtualBus::new(Bitrate::M1);
    let (mut a, mut b, mut c) = (bus.node(), bus.node(), bus.node());
    let frames: Vec<CanFrame> = (0..5u8)
        .map(|i| std_frame(0x300 + u16::from(i), &[i; 4]))
        .collect();
    let sent = frames.clone();
    let start = Instant::now();
    let tx = tokio::spawn(async move {
        for f in &sent {
            send_frame(&mut a, f).await.unwrap();
        }
        a
    });
    let mut end = start;
    for f in &frames {
        let got_b = recv_frame(&mut b).await.unwrap();
        let got_c = recv_frame(&mut c).await.unwrap();
        assert_eq!((got_b.frame, got_c.frame), (*f, *f));
        assert_eq!(got_b.at, got_c.at);
        end += f.duration(Bitrate::M1);
        assert_eq!(got_b.at, end, "{f}");
    }
    let a = tx.await.unwrap();
    assert_eq!(a.stats().sent, 5);
    // No echo by default.
    assert_eq!(a.pending_rx(), 0);
}

#[tokio::test(start_paused = true)]
async fn echo_delivers_own_frames() {
    let bus = VirtualBus::with_config(BusConfig {
        echo: true,
        ..BusConfig::new(Bitrate::K125)
    });
    let (mut a, _b) = (bus.node(), bus.node());
    let f = std_frame(0x7FF, &[]);
    send_frame(&mut a, &f).await.unwrap();
    assert_eq!(recv_frame(&mut a).await.unwrap().frame, f);
}

#[tokio::test(start_paused = true)]
async fn a_slow_reader_overruns_a_bounded_queue_and_sees_the_count() {
    let bus = VirtualBus::with_config(BusConfig {
        rx_capacity: 4,
        ..BusConfig::new(Bitrate::M1)
    });
    let (mut a, mut b) = (bus.node(), bus.node());
    for i in 0..10u8 {
        send_frame(&mut a, &std_frame(0x10, &[i])).await.unwrap();
    }
    assert_eq!(b.pending_rx(), 4);
    assert_eq!(b.stats().overruns, 6);
    // The oldest four are kept, the newest lost.
    for i in 0..4u8 {
        assert_eq!(recv_frame(&mut b).await.unwrap().frame.data_array()[0], i);
    }
}

#[tokio::test(start_paused = true)]
async fn the_bus_ends_when_the_last_peer_and_handle_are_gone() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, b) = (bus.node(), bus.node());
    drop(b);
    // The handle could still attach a peer: no end of file yet.
    assert!(
        timeout(Duration::from_secs(1), recv_frame(&mut a))
            .await
            .is_err()
    );
    drop(bus);
    let err = recv_frame(&mut a).await.unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::UnexpectedEof);
    let err = send_frame(&mut a, &std_frame(1, &[])).await.unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::BrokenPipe);
}

#[tokio::test(start_paused = true)]
async fn frames_in_flight_are_still_delivered_after_the_sender_is_gone() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b) = (bus.node(), bus.node());
    let f = std_frame(0x55, &[1, 2]);
    send_frame(&mut a, &f).await.unwrap();
    drop(a);
    drop(bus);
    assert_eq!(recv_frame(&mut b).await.unwrap().frame, f);
    assert_eq!(
        recv_frame(&mut b).await.unwrap_err().kind(),
        io::ErrorKind::UnexpectedEof
    );
}

#[tokio::test(start_paused = true)]
async fn a_dropped_frame_reaches_nobody_but_takes_its_time() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b) = (bus.node(), bus.node());
    let lost = std_frame(0x20, &[0xAA; 8]);
    let next = std_frame(0x21, &[]);
    let start = Instant::now();
    a.inject(BusFault::Drop);
    send_frame(&mut a, &lost).await.unwrap();
    send_frame(&mut a, &next).await.unwrap();
    let got = recv_frame(&mut b).await.unwrap();
    assert_eq!(got.frame, next);
    assert_eq!(
        got.at - start,
        lost.duration(Bitrate::K500) + next.duration(Bitrate::K500)
    );
    assert_eq!(a.stats().dropped, 1);
}

#[tokio::test(start_paused = true)]
async fn a_corrupted_frame_is_seen_once_after_its_retransmission() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b) = (bus.node(), bus.node());
    let f = std_frame(0x123, &[1, 2, 3, 4, 5, 6, 7, 8]);
    let start = Instant::now();
    a.inject(BusFault::Corrupt);
    send_frame(&mut a, &f).await.unwrap();
    let got = recv_frame(&mut b).await.unwrap();
    assert_eq!(got.frame, f);
    // Destroyed transmission (frame + error frame − EOF/intermission: bits + 7), then the
    // retransmission.
    let destroyed = Bitrate::K500.bits_duration(f.bits() + 7);
    assert_eq!(got.at - start, destroyed + f.duration(Bitrate::K500));
    assert_eq!(b.pending_rx(), 0, "received once");
    assert_eq!(a.stats().corrupted, 1);
}

#[tokio::test(start_paused = true)]
async fn one_shot_mode_loses_a_corrupted_frame_and_says_so() {
    let bus = VirtualBus::with_config(BusConfig::new(Bitrate::K500).with_faults(BusFaults {
        one_shot: true,
        ..BusFaults::none()
    }));
    let (mut a, mut b) = (bus.node(), bus.node());
    a.inject(BusFault::Corrupt);
    let err = send_frame(&mut a, &std_frame(1, &[1])).await.unwrap_err();
    assert!(err.to_string().contains("one-shot"), "{err}");
    assert!(
        timeout(Duration::from_millis(50), recv_frame(&mut b))
            .await
            .is_err()
    );
    assert_eq!(a.stats().abandoned, 1);
}

#[tokio::test(start_paused = true)]
async fn a_delayed_request_loses_arbitration_to_a_later_one() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, mut b, mut rx) = (bus.node(), bus.node(), bus.node());
    a.inject(BusFault::Delay(Duration::from_millis(2)));
    let ta = tokio::spawn(async move { send_frame(&mut a, &std_frame(0x001, &[])).await });
    let tb = tokio::spawn(async move { send_frame(&mut b, &std_frame(0x700, &[])).await });
    assert_eq!(recv_frame(&mut rx).await.unwrap().frame.raw_id(), 0x700);
    let late = recv_frame(&mut rx).await.unwrap();
    assert_eq!(late.frame.raw_id(), 0x001);
    ta.await.unwrap().unwrap();
    tb.await.unwrap().unwrap();
}

async fn campaign(seed: u64) -> (u64, u64, Vec<u16>) {
    let bus = VirtualBus::with_config(BusConfig::new(Bitrate::M1).with_faults(BusFaults {
        seed,
        drop: 0.1,
        corrupt: 0.1,
        ..BusFaults::none()
    }));
    let (mut a, mut b) = (bus.node(), bus.node());
    for i in 0..200u16 {
        send_frame(&mut a, &std_frame(i, &[])).await.unwrap();
    }
    let mut ids = Vec::new();
    while b.pending_rx() > 0 {
        ids.push(
            recv_frame(&mut b)
                .await
                .unwrap()
                .frame
                .standard_id()
                .unwrap(),
        );
    }
    (a.stats().dropped, a.stats().corrupted, ids)
}

#[tokio::test(start_paused = true)]
async fn random_faults_are_reproducible_and_never_reorder_or_duplicate() {
    let first = campaign(7).await;
    let again = campaign(7).await;
    assert_eq!(first, again);
    let (dropped, corrupted, ids) = first;
    assert!(dropped > 5 && corrupted > 5, "{dropped} {corrupted}");
    assert_eq!(ids.len() as u64, 200 - dropped);
    assert!(
        ids.windows(2).all(|w| w[0] < w[1]),
        "in order, no duplicates"
    );
    assert_ne!(campaign(8).await.2, ids);
}

#[tokio::test]
async fn untimed_mode_delivers_at_once() {
    let bus = VirtualBus::with_config(BusConfig::untimed());
    let (mut a, mut b) = (bus.node(), bus.node());
    for i in 0..100u16 {
        send_frame(&mut a, &std_frame(i, &[1])).await.unwrap();
        assert_eq!(
            recv_frame(&mut b).await.unwrap().frame.raw_id(),
            u32::from(i)
        );
    }
}
