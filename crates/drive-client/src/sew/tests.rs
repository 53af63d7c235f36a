use super::*;

/// A drive whose first `failures` services answer "internal communication error" (6/2), then
/// 1234; at address 1 of a bus without settings of its own.
#[derive(Debug, Default)]
struct Flaky {
    failures: u32,
    calls: u32,
}

impl SewLink for Flaky {
    async fn service(&mut self, _: ParamChannel) -> Result<u32, ClientError> {
        self.calls += 1;
        if self.calls <= self.failures {
            Err(device_error(
                ReturnCode::INTERNAL_COMMUNICATION_ERROR,
                "internal communication error".into(),
            ))
        } else {
            Ok(1234)
        }
    }
    fn bus_key(&self) -> String {
        "test".into()
    }
    async fn drive_address(&mut self) -> Result<String, ClientError> {
        Ok("1".into())
    }
    fn link_settings(&self) -> &'static [u16] {
        &[]
    }
    fn not_restored(&self) -> &'static [u16] {
        &[]
    }
    fn link_change(&self, _: &Target, _: i64, _: &dyn FrontEnd) -> String {
        String::new()
    }
    fn address_number(&self) -> u8 {
        1
    }
}

fn p130() -> Target {
    Target::resolve(Family::Movidrive, "P130", RAW_INDICES).unwrap()
}

#[tokio::test]
async fn a_passing_fault_is_repeated_up_to_the_attempts() {
    let mut c = SewClient::new(Flaky {
        failures: 2,
        ..Flaky::default()
    });
    assert_eq!(c.read(&p130()).await.unwrap(), 1234);
    assert_eq!(c.link.calls, 3);
    let mut c = SewClient::new(Flaky {
        failures: 3,
        ..Flaky::default()
    });
    match c.read(&p130()).await {
        Err(ClientError::Device(d)) => assert_eq!(d.kind, DeviceErrorKind::Transient),
        other => panic!("{other:?}"),
    }
    assert_eq!(c.link.calls, SERVICE_ATTEMPTS);
    assert_eq!(c.drive_key().await.unwrap(), "test 1");
}

#[test]
fn raw_values_and_write_services() {
    let t = p130();
    assert_eq!(raw_of(&t, 0xFFFF_FFFF), 0xFFFF_FFFF);
    let raw = Target::resolve(Family::Movidrive, "9999", RAW_INDICES).unwrap();
    assert_eq!(raw_of(&raw, 0xFFFF_FFFF), -1);
    assert_eq!(
        write_service(8470, -1, Persistence::Volatile),
        ParamChannel::write_volatile(8470, 0xFFFF_FFFF)
    );
    assert_eq!(
        write_service(8470, 5, Persistence::NonVolatile),
        ParamChannel::write(8470, 5)
    );
}

#[test]
fn the_stop_command_goes_into_the_control_word_slots_only() {
    let words = [0x0006, 5000, 0x1206];
    assert_eq!(
        with_command(&words, &[0, 2], ControlWord1::STOP),
        [0x0002, 5000, 0x1202]
    );
    assert_eq!(with_command(&words, &[7], ControlWord1::STOP), words);
}
