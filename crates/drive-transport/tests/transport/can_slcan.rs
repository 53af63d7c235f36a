//! slcan: the client against the simulated adapter over a real pseudo-terminal, and against
//! scripted adapters over an in-memory stream.

use std::io;
use std::time::Duration;

use drive_core::can::{Bitrate, CanFrame, ExtendedId, StandardId};
use drive_core::rt::{recv_frame, send_frame};
use drive_transport::TransportError;
use drive_transport::can::VirtualBus;
use drive_transport::can::slcan::{self, Rejection, SlcanAdapter, SlcanPort};
use drive_transport::pty::PtyPair;
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};
use tokio::time::timeout;

const LIMIT: Duration = Duration::from_secs(5);

/// A virtual bus at 500 kbit/s with a simulated adapter on a pty; returns the bus, another
/// node and the pty slave's path.
fn adapter_on_pty() -> (VirtualBus, drive_transport::can::VirtualNode, String) {
    let bus = VirtualBus::new(Bitrate::K500);
    let pty = PtyPair::open().unwrap();
    let path = pty.slave_path().to_string_lossy().into_owned();
    let adapter = SlcanAdapter::new(pty, bus.node(), Bitrate::K500);
    tokio::spawn(adapter.run());
    let other = bus.node();
    (bus, other, path)
}

#[tokio::test]
async fn frames_both_ways_through_a_pty_and_the_simulated_adapter() {
    let (_bus, mut other, path) = adapter_on_pty();
    timeout(LIMIT, async {
        let mut port = SlcanPort::open(&path, Bitrate::K500).await.unwrap();
        // Standard data frame from the bus to the client.
        let f = CanFrame::standard(0x10C, &[0x00, 0x07, 0x13, 0x89, 0, 0]).unwrap();
        send_frame(&mut other, &f).await.unwrap();
        assert_eq!(recv_frame(&mut port).await.unwrap().frame, f);
        // Extended data, standard remote and extended remote frames from the client.
        let ext =
            CanFrame::data_frame(ExtendedId::new(0x1234_5678).unwrap(), &[0xDE, 0xAD]).unwrap();
        let rtr = CanFrame::remote_frame(StandardId::new(0x7FF).unwrap(), 8).unwrap();
        let ertr = CanFrame::remote_frame(ExtendedId::new(0x1FFF_FFFF).unwrap(), 0).unwrap();
        for frame in [ext, rtr, ertr] {
            send_frame(&mut port, &frame).await.unwrap();
            assert_eq!(recv_frame(&mut other).await.unwrap().frame, frame);
        }
        // And an extended and a remote frame back.
        for frame in [ext, rtr] {
            send_frame(&mut other, &frame).await.unwrap();
            assert_eq!(recv_frame(&mut port).await.unwrap().frame, frame);
        }
        let stats = port.stats();
        assert_eq!((stats.sent, stats.received, stats.rejected), (3, 3, 0));
    })
    .await
    .expect("slcan over pty timed out");
}

#[tokio::test]
async fn a_bit_rate_without_an_s_code_is_refused_naming_the_valid_ones() {
    let err = SlcanPort::open("/dev/null", Bitrate::new(83_333).unwrap())
        .await
        .unwrap_err();
    assert!(matches!(
        err,
        TransportError::SlcanBitrate { bitrate: 83_333 }
    ));
    let msg = err.to_string();
    assert!(
        msg.contains("83333") && msg.contains("125, 250, 500, 800 and 1000 kbit/s"),
        "{msg}"
    );
    assert_eq!(slcan::s_code(Bitrate::K10).unwrap(), b'0');
    assert_eq!(slcan::s_code(Bitrate::M1).unwrap(), b'8');
    assert_eq!(slcan::bitrate_of_code(b'6'), Some(Bitrate::K500));
    assert_eq!(slcan::bitrate_of_code(b'9'), None);
}

#[tokio::test]
async fn a_different_bit_rate_than_the_bus_fails_every_transmit() {
    let (_bus, mut other, path) = adapter_on_pty();
    timeout(LIMIT, async {
        let mut port = SlcanPort::open(&path, Bitrate::K250).await.unwrap();
        let err = send_frame(&mut port, &CanFrame::standard(1, &[]).unwrap())
            .await
            .unwrap_err();
        assert!(err.to_string().contains("refused"), "{err}");
        // Nothing from the bus reaches it either.
        send_frame(&mut other, &CanFrame::standard(2, &[]).unwrap())
            .await
            .unwrap();
        assert!(
            timeout(Duration::from_millis(100), recv_frame(&mut port))
                .await
                .is_err()
        );
    })
    .await
    .expect("timed out");
}

#[tokio::test]
async fn the_simulated_adapter_answers_bel_to_frames_before_open_and_bad_commands() {
    let bus = VirtualBus::new(Bitrate::K500);
    let (mut client, adapter_end) = tokio::io::duplex(1024);
    tokio::spawn(SlcanAdapter::new(adapter_end, bus.node(), Bitrate::K500).run());
    let mut other = bus.node();
    let mut answer = async |line: &[u8]| {
        client.write_all(line).await.unwrap();
        let mut buf = [0u8; 16];
        let n = client.read(&mut buf).await.unwrap();
        buf[..n].to_vec()
    };
    assert_eq!(answer(b"t1230\r").await, b"\x07", "frame before O");
    assert_eq!(answer(b"O\r").await, b"\x07", "O without a bit rate");
    assert_eq!(answer(b"S9\r").await, b"\x07", "no such S code");
    assert_eq!(answer(b"Q\r").await, b"\x07", "unknown command");
    assert_eq!(answer(b"S6\r").await, b"\r");
    assert_eq!(answer(b"O\r").await, b"\r");
    assert_eq!(answer(b"S4\r").await, b"\x07", "S while open");
    assert_eq!(answer(b"t12G0\r").await, b"\x07", "bad hex");
    assert_eq!(
        answer(b"t12310\r").await,
        b"\x07",
        "data shorter than its length"
    );
    assert_eq!(answer(b"t1231AB\r").await, b"z\r");
    assert_eq!(answer(b"T000001231AB\r").await, b"Z\r");
    assert_eq!(
        recv_frame(&mut other).await.unwrap().frame.to_string(),
        "123#AB"
    );
    assert_eq!(
        recv_frame(&mut other).await.unwrap().frame.to_string(),
        "00000123#AB"
    );
    assert_eq!(answer(b"C\r").await, b"\r");
    assert_eq!(answer(b"C\r").await, b"\x07", "already closed");
}

/// A scripted adapter: answers each command line with the next answer of `answers`, then
/// writes `after` and keeps the stream open.
fn scripted(answers: Vec<&'static [u8]>, after: &'static [u8]) -> DuplexStream {
    let (client, mut adapter) = tokio::io::duplex(4096);
    tokio::spawn(async move {
        let mut buf = [0u8; 64];
        for answer in answers {
            // Read one command line.
            let mut line = Vec::new();
            while !line.ends_with(b"\r") {
                let n = adapter.read(&mut buf).await.unwrap();
                if n == 0 {
                    return;
                }
                line.extend_from_slice(&buf[..n]);
            }
            adapter.write_all(answer).await.unwrap();
        }
        adapter.write_all(after).await.unwrap();
        // Keep the line open until the client hangs up.
        while adapter.read(&mut buf).await.unwrap_or(0) > 0 {}
    });
    client
}

#[tokio::test(start_paused = true)]
async fn an_adapter_that_answers_bel_is_a_typed_error() {
    let io = scripted(vec![b"\x07", b"\x07", b"\x07"], b"");
    let err = SlcanPort::new(io, "scripted", Bitrate::K500)
        .await
        .unwrap_err();
    assert!(
        matches!(&err, TransportError::SlcanRefused { command, .. } if command.starts_with("S6")),
        "{err}"
    );
    assert!(
        err.to_string()
            .contains("refused the command S6 (500 kbit/s)"),
        "{err}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_silent_adapter_is_a_typed_error() {
    let io = scripted(vec![], b"");
    let err = SlcanPort::new(io, "scripted", Bitrate::K500)
        .await
        .unwrap_err();
    assert!(
        matches!(&err, TransportError::SlcanNoAnswer { command, .. } if command == "C"),
        "{err}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_transmit_answered_with_bel_is_an_error_and_plain_cr_is_accepted() {
    let io = scripted(
        vec![b"\r", b"\r", b"\r", b"\r", b"\x07", b"\r", b"z\r"],
        b"",
    );
    let mut port = SlcanPort::new(io, "scripted", Bitrate::K500).await.unwrap();
    let f = CanFrame::standard(1, &[1]).unwrap();
    assert!(send_frame(&mut port, &f).await.is_err());
    send_frame(&mut port, &f).await.unwrap();
    send_frame(&mut port, &f).await.unwrap();
    let err = send_frame(&mut port, &f).await.unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::TimedOut, "{err}");
}

#[tokio::test(start_paused = true)]
async fn garbage_lines_are_counted_rejections_never_frames() {
    let garbage: &'static [u8] = b"t12\r\
        tXYZ0\r\
        t1239\r\
        t123200112\r\
        t12320\r\
        T200000000\r\
        t8000\r\
        x\r\
        t123101234\r\
        t1230000000000000000000000000000000000000000\r\
        \r\
        t1232BEEF\r";
    let io = scripted(vec![b"\r", b"\r", b"\r", b"\r"], garbage);
    let mut port = SlcanPort::new(io, "scripted", Bitrate::K500).await.unwrap();
    // Only the last line is a frame.
    let got = recv_frame(&mut port).await.unwrap();
    assert_eq!(got.frame.to_string(), "123#BEEF");
    let stats = port.stats();
    assert_eq!(stats.received, 1);
    assert_eq!(stats.rejected, 11, "{stats:?}");
    assert_eq!(stats.last_rejection, Some(Rejection::StrayAnswer));
}

#[test]
fn the_line_codec_is_strict() {
    use slcan::parse_frame;
    assert_eq!(parse_frame(b"t12").unwrap_err(), Rejection::BadId);
    assert_eq!(parse_frame(b"tXYZ0").unwrap_err(), Rejection::BadId);
    assert_eq!(parse_frame(b"t1239").unwrap_err(), Rejection::BadLength);
    assert_eq!(
        parse_frame(b"t12320011FF").unwrap_err(),
        Rejection::WrongLength {
            expected: 9,
            got: 11
        }
    );
    assert_eq!(parse_frame(b"t8000").unwrap_err(), Rejection::BadId);
    assert_eq!(parse_frame(b"T200000000").unwrap_err(), Rejection::BadId);
    assert_eq!(parse_frame(b"t1231G0").unwrap_err(), Rejection::BadData);
    assert_eq!(parse_frame(b"r1238").unwrap().to_string(), "123#R8");
    assert_eq!(
        parse_frame(b"r12380011").unwrap_err(),
        Rejection::WrongLength {
            expected: 5,
            got: 9
        }
    );
    assert_eq!(parse_frame(b"t7ff0").unwrap().to_string(), "7FF#");
    let mut buf = [0u8; slcan::MAX_LINE + 1];
    let longest = CanFrame::data_frame(ExtendedId::new(0x1FFF_FFFF).unwrap(), &[0xFF; 8]).unwrap();
    let n = slcan::encode(&longest, &mut buf);
    assert_eq!(&buf[..n], b"T1FFFFFFF8FFFFFFFFFFFFFFFF\r");
    assert_eq!(parse_frame(&buf[..n - 1]).unwrap(), longest);
}

#[tokio::test]
async fn slcan_open_names_a_missing_port() {
    let err = SlcanPort::open("/dev/ttyNOSUCH-slcan", Bitrate::K500)
        .await
        .unwrap_err();
    assert!(matches!(err, TransportError::NotFound { .. }), "{err}");
}
