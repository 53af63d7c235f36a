//! SocketCAN. The tests against `vcan0` need the vcan kernel module and run only with
//! `--features vcan-tests` (README.md says how); the error for a missing interface is tested
//! everywhere.

use drive_transport::TransportError;
use drive_transport::can::SocketCanPort;

#[tokio::test]
async fn a_missing_interface_is_named_with_what_to_do() {
    let err = SocketCanPort::open("nosuchcan7").unwrap_err();
    match &err {
        TransportError::CanInterfaceNotFound { name, .. } => assert_eq!(name, "nosuchcan7"),
        // A kernel without SocketCAN at all says so instead.
        TransportError::Unsupported { setting, .. } => assert_eq!(setting, "SocketCAN"),
        other => panic!("unexpected error: {other}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("nosuchcan7"), "{msg}");
    if matches!(err, TransportError::CanInterfaceNotFound { .. }) {
        assert!(msg.contains("ip link add nosuchcan7 type vcan"), "{msg}");
        assert!(
            msg.contains("ip link set nosuchcan7 up type can bitrate 500000"),
            "{msg}"
        );
    }
}

#[cfg(feature = "vcan-tests")]
mod vcan {
    //! Against `vcan0` (`sudo ip link add vcan0 type vcan && sudo ip link set vcan0 up`).

    use std::time::Duration;

    use drive_core::can::{CanFrame, ExtendedId, StandardId};
    use drive_core::rt::{recv_frame, send_frame};
    use drive_transport::can::SocketCanPort;
    use tokio::time::timeout;

    const LIMIT: Duration = Duration::from_secs(5);

    #[tokio::test]
    async fn frames_pass_between_two_sockets_on_vcan0() {
        let mut a = SocketCanPort::open("vcan0").expect("vcan0 (see README.md)");
        let mut b = SocketCanPort::open("vcan0").unwrap();
        let frames = [
            CanFrame::standard(0x10B, &[0, 6, 0x13, 0x88, 0, 0]).unwrap(),
            CanFrame::standard(0x000, &[]).unwrap(),
            CanFrame::data_frame(ExtendedId::new(0x1234_5678).unwrap(), &[1, 2, 3]).unwrap(),
            CanFrame::remote_frame(StandardId::new(0x7FF).unwrap(), 4).unwrap(),
            CanFrame::remote_frame(ExtendedId::new(0x1FFF_FFFF).unwrap(), 0).unwrap(),
        ];
        timeout(LIMIT, async {
            for f in &frames {
                send_frame(&mut a, f).await.unwrap();
                assert_eq!(recv_frame(&mut b).await.unwrap().frame, *f);
            }
        })
        .await
        .expect("vcan0 round trip timed out");
        assert_eq!(a.stats().sent, 5);
        assert_eq!(b.stats().received, 5);
        // A socket does not receive its own frames.
        assert!(
            timeout(Duration::from_millis(100), recv_frame(&mut a))
                .await
                .is_err()
        );
    }
}
