//! Pseudo-terminals and serial ports (real file descriptors, no hardware).

use std::time::Duration;

use drive_transport::pty::PtyPair;
use drive_transport::serial::{self, Parity, Rs485Config, SerialConfig};
use drive_transport::{LineOption, TransportError};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::time::timeout;

const LIMIT: Duration = Duration::from_secs(5);

async fn send_and_receive(
    tx: &mut (impl AsyncWrite + Unpin),
    rx: &mut (impl AsyncRead + Unpin),
    data: &[u8],
) -> Vec<u8> {
    let mut got = vec![0u8; data.len()];
    let (w, r) = tokio::join!(tx.write_all(data), rx.read_exact(&mut got));
    w.unwrap();
    r.unwrap();
    got
}

fn all_bytes() -> Vec<u8> {
    (0..=255u8).chain((0..=255u8).rev()).collect()
}

#[tokio::test]
async fn all_byte_values_pass_through_serial_open_on_a_pty() {
    let mut pty = PtyPair::open().unwrap();
    assert!(pty.slave_path().starts_with("/dev/pts/"));
    let mut port = serial::open(&pty.slave_config(9600)).unwrap();
    assert_eq!(port.config().line.parity, Parity::None);
    let data = all_bytes();
    timeout(LIMIT, async {
        assert_eq!(send_and_receive(&mut pty, &mut port, &data).await, data);
        assert_eq!(send_and_receive(&mut port, &mut pty, &data).await, data);
    })
    .await
    .expect("pty round trip timed out");
}

#[tokio::test]
async fn both_stream_ends_are_transparent() {
    let (mut master, mut slave) = PtyPair::open_streams().unwrap();
    let data = all_bytes();
    timeout(LIMIT, async {
        assert_eq!(send_and_receive(&mut master, &mut slave, &data).await, data);
        assert_eq!(send_and_receive(&mut slave, &mut master, &data).await, data);
        // Closing one side is end of file on the other.
        drop(slave);
        let mut rest = Vec::new();
        master.read_to_end(&mut rest).await.unwrap();
        assert!(rest.is_empty());
    })
    .await
    .expect("pty streams timed out");
}

#[tokio::test]
async fn pty_refuses_parity_even_naming_the_setting() {
    let pty = PtyPair::open().unwrap();
    let path = pty.slave_path().to_string_lossy().into_owned();
    for (parity, name) in [(Parity::Even, "parity even"), (Parity::Odd, "parity odd")] {
        let mut cfg = pty.slave_config(9600);
        cfg.line.parity = parity;
        match serial::open(&cfg) {
            Err(err @ TransportError::Unsupported { .. }) => {
                assert_eq!(err.refused_setting(), Some(LineOption::Parity));
                let TransportError::Unsupported {
                    setting,
                    path: p,
                    hint,
                } = err
                else {
                    unreachable!()
                };
                assert_eq!(setting, name);
                assert_eq!(p, path);
                // A library names no command-line option; the front end adds its own.
                assert!(hint.contains("no parity") && !hint.contains("--"), "{hint}");
            }
            other => panic!("expected Unsupported, got {other:?}"),
        }
    }
    let err = serial::open(&SerialConfig::new(path.clone(), 9600)).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("parity even") && msg.contains(&path), "{msg}");
    assert_eq!(err.io_kind(), std::io::ErrorKind::Unsupported);
}

#[tokio::test]
async fn rs485_mode_on_a_pty_is_a_clear_error() {
    let pty = PtyPair::open().unwrap();
    let cfg = SerialConfig {
        rs485: Some(Rs485Config::default()),
        ..pty.slave_config(9600)
    };
    match serial::open(&cfg) {
        Err(err @ TransportError::Unsupported { .. }) => {
            let msg = err.to_string();
            assert!(msg.contains("RS-485 mode"), "{msg}");
            assert_eq!(err.refused_setting(), Some(LineOption::Rs485));
            if let TransportError::Unsupported { setting, hint, .. } = err {
                assert_eq!(setting, "RS-485 mode");
                assert!(hint.contains("automatic direction control"), "{hint}");
            }
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[tokio::test]
async fn opening_a_nonexistent_port_names_the_path() {
    let path = "/dev/ttyDRIVEBUS-does-not-exist";
    let err = serial::open(&SerialConfig::new(path, 9600)).unwrap_err();
    match &err {
        TransportError::NotFound { path: p } => assert_eq!(p, path),
        other => panic!("expected NotFound, got {other:?}"),
    }
    assert!(err.to_string().contains(path));
    assert_eq!(
        std::io::Error::from(err).kind(),
        std::io::ErrorKind::NotFound
    );
}

#[tokio::test]
async fn opening_a_regular_file_says_it_is_not_a_serial_device() {
    let dir = std::env::temp_dir().join(format!("drive-transport-test-{}", std::process::id()));
    std::fs::write(&dir, b"").unwrap();
    let path = dir.to_string_lossy().into_owned();
    let result = serial::open(&SerialConfig::new(path.clone(), 9600));
    std::fs::remove_file(&dir).unwrap();
    match result {
        Err(TransportError::Unsupported {
            setting,
            path: p,
            hint,
        }) => {
            assert_eq!(setting, "serial port access");
            assert_eq!(p, path);
            assert!(hint.contains("not a character device"), "{hint}");
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[tokio::test]
async fn invalid_settings_are_rejected_before_opening() {
    let mut cfg = SerialConfig::new("/dev/null", 9600);
    cfg.line.data_bits = 9;
    assert!(matches!(
        serial::open(&cfg),
        Err(TransportError::InvalidConfig { .. })
    ));
    assert!(matches!(
        serial::open(&SerialConfig::new("/dev/null", 0)),
        Err(TransportError::InvalidConfig { .. })
    ));
}

#[test]
fn outside_a_runtime_open_fails_instead_of_panicking() {
    let err = serial::open(&SerialConfig::new("/dev/null", 9600)).unwrap_err();
    assert!(err.to_string().contains("tokio runtime"), "{err}");
    assert!(PtyPair::open().is_err());
}

#[tokio::test]
async fn a_port_opened_twice_is_busy() {
    let pty = PtyPair::open().unwrap();
    let first = serial::open(&pty.slave_config(9600)).unwrap();
    match serial::open(&pty.slave_config(9600)) {
        Err(TransportError::Busy { path, hint }) => {
            assert_eq!(path, first.config().path);
            assert!(hint.contains("another program"), "{hint}");
        }
        other => panic!("expected Busy, got {other:?}"),
    }
}

#[tokio::test]
async fn opening_a_character_device_without_a_terminal_says_it_is_not_a_serial_port() {
    // /dev/null is a character device but has no terminal settings (ENOTTY).
    let err = serial::open(&SerialConfig::new("/dev/null", 9600)).unwrap_err();
    match &err {
        TransportError::Unsupported {
            setting,
            path,
            hint,
        } => {
            assert_eq!(setting, "serial port access");
            assert_eq!(path, "/dev/null");
            assert!(hint.contains("not a serial port"), "{hint}");
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

/// Issue 18: what an earlier program left in the port (here: an answer the drive side wrote
/// while nobody read) is discarded when the port is opened and counted; what comes after the
/// open is read.
#[tokio::test]
async fn issue18_open_discards_what_the_input_holds_and_counts_it() {
    let mut pty = PtyPair::open().unwrap();
    // A first program opens the port, the drive answers, the program leaves without reading.
    let first = serial::open(&pty.slave_config(9600)).unwrap();
    assert_eq!(first.flushed_at_open(), 0);
    pty.write_all(&[0x01, 0x03, 0x02, 0x05, 0x6E, 0xBB, 0x7A])
        .await
        .unwrap();
    pty.flush().await.unwrap();
    // The pty carries the bytes into the slave's input on its own time.
    tokio::time::sleep(Duration::from_millis(50)).await;
    drop(first);
    let mut port = serial::open(&pty.slave_config(9600)).unwrap();
    assert_eq!(port.flushed_at_open(), 7);
    timeout(LIMIT, async {
        assert_eq!(send_and_receive(&mut pty, &mut port, b"new").await, b"new");
    })
    .await
    .expect("pty round trip timed out");
}

/// A pseudo-terminal has no wire time; a serial port is a `CharIo` that says so.
#[tokio::test]
async fn issue18_a_pty_port_is_known_to_have_no_wire_time() {
    use drive_core::rt::{CharIo, WireTime};
    let pty = PtyPair::open().unwrap();
    let port = serial::open(&pty.slave_config(9600)).unwrap();
    assert!(port.is_pty());
    assert_eq!(port.wire_time(), WireTime::None);
}
