//! candump logs: reading (through socketcan's parser), writing, capture and replay.

use std::io::Cursor;
use std::time::Duration;

use drive_core::can::{Bitrate, CanFrame, ExtendedId, StandardId};
use drive_core::rt::{recv_frame, send_frame};
use drive_transport::can::VirtualBus;
use drive_transport::can::candump::{
    Capture, LogErrorKind, LogReader, LogRecord, read_file, replay, write_record,
};
use tokio::time::Instant;

fn records() -> Vec<LogRecord> {
    let frames = [
        CanFrame::standard(0x10B, &[0x00, 0x06, 0x13, 0x88, 0x00, 0x00]).unwrap(),
        CanFrame::standard(0x000, &[]).unwrap(),
        CanFrame::data_frame(ExtendedId::new(0x1FFF_FFFF).unwrap(), &[0xFF; 8]).unwrap(),
        CanFrame::data_frame(ExtendedId::new(0x123).unwrap(), &[1]).unwrap(),
        CanFrame::remote_frame(StandardId::new(0x7FF).unwrap(), 8).unwrap(),
        CanFrame::remote_frame(ExtendedId::new(0x42).unwrap(), 0).unwrap(),
    ];
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| LogRecord {
            t_us: 1_735_270_496_916_858 + 1013 * i as u64,
            interface: if i % 2 == 0 {
                "can0".into()
            } else {
                "vcan1".into()
            },
            frame: *f,
        })
        .collect()
}

fn read_all(text: &[u8]) -> Vec<LogRecord> {
    LogReader::new(Cursor::new(text))
        .collect::<Result<_, _>>()
        .unwrap()
}

#[test]
fn read_of_write_is_the_identity() {
    let recs = records();
    let mut out = Vec::new();
    for r in &recs {
        write_record(&mut out, r).unwrap();
    }
    let text = String::from_utf8(out.clone()).unwrap();
    assert!(
        text.starts_with("(1735270496.916858) can0 10B#000613880000\n"),
        "{text}"
    );
    assert!(text.contains(" vcan1 000#\n"), "{text}");
    assert!(text.contains(" can0 1FFFFFFF#FFFFFFFFFFFFFFFF\n"), "{text}");
    assert!(text.contains(" vcan1 00000123#01\n"), "{text}");
    assert!(text.contains(" can0 7FF#R8\n"), "{text}");
    assert!(text.contains(" vcan1 00000042#R\n"), "{text}");
    assert_eq!(read_all(&out), recs);
}

#[test]
fn a_notepad_file_with_bom_and_crlf_reads() {
    let text = "\u{feff}(1469439874.299591) can1 080#\r\n\r\n(1469439874.299654) can1 701#7F\r\n";
    let recs = read_all(text.as_bytes());
    assert_eq!(recs.len(), 2);
    assert_eq!(recs[0].t_us, 1_469_439_874_299_591);
    assert_eq!(recs[0].interface, "can1");
    assert_eq!(recs[0].frame.to_string(), "080#");
    assert_eq!(recs[1].frame.to_string(), "701#7F");
}

#[test]
fn errors_name_their_line() {
    let text = b"(1.000000) can0 123#01\n\n(2.000000) can0 123#0\n(3.000000) can0 123##400\n\
        (4.000000) can0 20000004#000C000000000000\n(5.5) can0 123#\n(6.000000) can0 123#01\n";
    let results: Vec<_> = LogReader::new(Cursor::new(&text[..])).collect();
    assert_eq!(results.len(), 6);
    assert!(results[0].is_ok());
    let errs: Vec<_> = results[1..5]
        .iter()
        .map(|r| r.as_ref().unwrap_err())
        .collect();
    assert_eq!(
        errs.iter().map(|e| e.line).collect::<Vec<_>>(),
        vec![3, 4, 5, 6]
    );
    assert!(matches!(errs[0].kind, LogErrorKind::Parse(_)));
    assert!(
        errs[0]
            .to_string()
            .starts_with("line 3: invalid CAN frame (expected"),
        "{}",
        errs[0]
    );
    assert!(matches!(errs[1].kind, LogErrorKind::FdFrame), "{}", errs[1]);
    assert!(
        matches!(errs[2].kind, LogErrorKind::ErrorFrame),
        "{}",
        errs[2]
    );
    assert!(
        errs[3].to_string().contains("invalid timestamp"),
        "{}",
        errs[3]
    );
    // Reading goes on after a bad line.
    assert_eq!(results[5].as_ref().unwrap().t_us, 6_000_000);
}

#[test]
fn an_overlong_or_binary_line_is_an_error_not_a_crash() {
    let mut text = vec![b'('; 5000];
    text.extend_from_slice(b"\n\xFF\xFE\n(1.000000) can0 123#01\n");
    let results: Vec<_> = LogReader::new(Cursor::new(text)).collect();
    assert!(matches!(
        results[0].as_ref().unwrap_err().kind,
        LogErrorKind::Overlong
    ));
    assert!(matches!(
        results[1].as_ref().unwrap_err().kind,
        LogErrorKind::NotText
    ));
    assert_eq!(results[1].as_ref().unwrap_err().line, 2);
    assert_eq!(results[2].as_ref().unwrap().frame.to_string(), "123#01");
}

#[test]
fn writing_refuses_an_interface_name_that_cannot_be_read_back() {
    let mut rec = records().remove(0);
    rec.interface = "can 0".into();
    assert!(write_record(&mut Vec::new(), &rec).is_err());
}

#[test]
fn read_file_reports_a_missing_file() {
    let err = read_file("/nonexistent/log.candump").unwrap_err();
    assert_eq!(err.line, 0);
    assert!(matches!(err.kind, LogErrorKind::Io(_)));
}

#[tokio::test(start_paused = true)]
async fn capture_logs_received_and_sent_frames_with_exact_times() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut a, b) = (bus.node(), bus.node());
    let start = Instant::now();
    let mut cap = Capture::with_epoch(b, Vec::new(), "vcan0", start, 1_000_000_000);
    let f1 = CanFrame::standard(0x10B, &[0, 6, 0x13, 0x88, 0, 0]).unwrap();
    send_frame(&mut a, &f1).await.unwrap();
    let got = recv_frame(&mut cap).await.unwrap();
    let f2 = CanFrame::standard(0x10C, &[0, 7]).unwrap();
    send_frame(&mut cap, &f2).await.unwrap();
    assert_eq!(cap.records(), 2);
    let (_, log) = cap.finish().unwrap();
    let recs = read_all(&log);
    assert_eq!(recs.len(), 2);
    assert_eq!(recs[0].frame, f1);
    let us = (got.at - start).as_micros() as u64;
    assert_eq!(recs[0].t_us, 1_000_000_000 + us);
    assert_eq!(recs[1].frame, f2);
    assert_eq!(recs[1].interface, "vcan0");
}

/// A capture does not lose a frame's intended start: the virtual bus places a frame sent with
/// `send_frame_at` at its start, and so must a capture wrapped around it (it did not forward
/// `poll_send_at`, so the frame went out at the late wake-up instead).
#[tokio::test(start_paused = true)]
async fn capture_keeps_the_intended_start_of_a_frame() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (a, mut b) = (bus.node(), bus.node());
    let mut cap = Capture::new(a, Vec::new(), "vcan0");
    let start = Instant::now();
    tokio::time::advance(Duration::from_micros(700)).await;
    let f = CanFrame::standard(0x10C, &[0, 7, 0, 0, 0, 0]).unwrap();
    drive_core::rt::send_frame_at(&mut cap, &f, start)
        .await
        .unwrap();
    let got = recv_frame(&mut b).await.unwrap();
    assert_eq!(got.frame, f);
    assert_eq!(got.at - start, f.duration(Bitrate::K500));
    assert_eq!(cap.records(), 1);
}

#[tokio::test(start_paused = true)]
async fn replay_keeps_the_relative_timing() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut player, mut rx) = (bus.node(), bus.node());
    let text = b"(100.000000) can0 001#01\n(100.005000) can0 002#02\n(100.012000) can0 003#03\n\
        (100.011000) can0 004#04\n";
    let recs = read_all(text);
    let start = Instant::now();
    let stats = tokio::spawn(async move { replay(&mut player, recs).await.unwrap() });
    let offsets = [0u64, 5, 12, 12];
    let mut prev_end = start;
    for (i, ms) in offsets.iter().enumerate() {
        let got = recv_frame(&mut rx).await.unwrap();
        assert_eq!(got.frame.raw_id(), i as u32 + 1);
        // Requested at start + offset (or when the previous frame was done, for the one
        // out of order), on the wire for its frame time.
        let requested = (start + Duration::from_millis(*ms)).max(prev_end);
        let d = got.frame.duration(Bitrate::K500);
        assert!(
            got.at >= requested + d && got.at <= requested + d + Duration::from_millis(1),
            "frame {i}: {:?} after start",
            got.at - start
        );
        if i < 3 {
            assert_eq!(got.at, requested + d, "frame {i}");
        }
        prev_end = got.at;
    }
    let stats = stats.await.unwrap();
    assert_eq!((stats.sent, stats.out_of_order), (4, 1));
}
