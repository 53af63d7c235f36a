//! The demo's CTT2 session: a simulated NORDAC LINK behind an AS-i master, on a virtual clock.

#[allow(unused_imports)]
use super::*;

/// A NORD session over CTT2: a simulated AS-i master and network (2 slaves: the NORDAC LINK's
/// double slave at 1A/1B) with the transfer-time model of BU 0255 ch. 4.4, on a virtual
/// clock: the ID and diagnosis objects, a parameter written and read back, the drive enabled
/// at 50 % through the state machine (the manual's 5.1.1/5.1.2) and stopped.
pub(super) async fn nord_session() -> Result<()> {
    use crate::nord::{Sub, resolve, state_text};
    use crate::tool::client::ParamClient;
    use ctt2_uss::client::{ClientConfig, NordClient};
    use ctt2_uss::ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
    use ctt2_uss::ctt2::master::{Ctt2Driver, DriverConfig};
    use drive_client::nord::NordParamClient;
    use drive_profile::Persistence;
    use drive_profile::nord::{ControlWord, State, command};

    let failed = |e: &dyn std::fmt::Display| CliError::failed(format!("demo: {e}"));
    let link = SimulatedLink::new(SimulatedDoubleSlave::default(), 2).map_err(|e| failed(&e))?;
    let byte = link.byte_time();
    outln!(
        "== NORD session: CTT2 through a simulated AS-i master ↔ NORDAC LINK double slave 1A/1B, 2 \
         AS-i slaves: {} ms per byte (virtual clock)",
        trim_float(byte.as_secs_f64() * 1e3, 3)
    )?;
    let started = drive_core::rt::time::now();
    let ms = || {
        trim_float(
            drive_core::rt::time::elapsed(started).as_secs_f64() * 1e3,
            0,
        )
    };
    let mut master = Ctt2Driver::new(link, DriverConfig::default());
    let id = master.read_id_object().await.map_err(|e| failed(&e))?;
    outln!(
        "  ID object: manufacturer 0x{:04X}, device 0x{:04X}, drive firmware {}.{}, configuration \
         level {} (t = {} ms)",
        id.manufacturer_id.unwrap_or(0),
        id.device_id.unwrap_or(0),
        id.firmware_version.unwrap_or(0),
        id.firmware_revision.unwrap_or(0),
        id.configuration_level.unwrap_or(0),
        ms()
    )?;
    let diag = master.read_diagnosis().await.map_err(|e| failed(&e))?;
    outln!("  diagnosis object: {diag} (t = {} ms)", ms())?;

    let mut client = NordClient::new(master, ClientConfig::default());
    let p102 = resolve(
        "P102",
        Sub {
            array: None,
            set: Some(3),
        },
        false,
    )?
    .into_iter()
    .next()
    .ok_or_else(|| failed(&"P102"))?;
    {
        let mut pc = NordParamClient::new(&mut client, "demo", serde_json::Map::new())
            .with_front_end(&crate::tool::front::Cli);
        pc.write(&p102, 1000, Persistence::NonVolatile)
            .await
            .map_err(|e| failed(&CliError::from(e)))?;
        outln!(
            "  write {} = 10.00 s (AK 2, IND 0200h, 03E8h): a NORD write of the PKW channel, then \
             NORD reads until the answer fits the order (t = {} ms)",
            p102.label(),
            ms()
        )?;
        let back = pc
            .read(&p102)
            .await
            .map_err(|e| failed(&CliError::from(e)))?;
        outln!(
            "  read back {}: {} (raw {back}) (t = {} ms)",
            p102.label(),
            p102.param.map_or_else(
                || back.to_string(),
                |p| crate::tool::output::physical_text(p, back)
            ),
            ms()
        )?;
        if back != 1000 {
            return Err(failed(&format!("P102 set 3 reads back {back}")));
        }
    }

    outln!("  enable at 50 % (SW1 2000h) through the state machine (5.1.1, 5.1.2):")?;
    let sw1 = [0x2000u16];
    let mut answer = client
        .process(ControlWord(0), &[], 1)
        .await
        .map_err(|e| failed(&e))?;
    let mut last = 0u16;
    for _ in 0..MAX_STEPS {
        let state = answer.status().state();
        let Some(word) = NordStateMachine::next_control(last, state, State::OperationEnabled)
        else {
            break;
        };
        answer = client
            .process(ControlWord(word), &sw1, 1)
            .await
            .map_err(|e| failed(&e))?;
        last = word;
        outln!(
            "    STW 0x{word:04X} → ZSW 0x{:04X} {} (t = {} ms)",
            answer.status().0,
            state_text(answer.status().state()),
            ms()
        )?;
    }
    let iw1 = |a: &ctt2_uss::uss::pzd::PzdIn| a.actuals().first().copied().unwrap_or(0);
    for _ in 0..40 {
        if answer.status().0 == 0x0B37 && iw1(&answer) == 0x2000 {
            break;
        }
        drive_core::rt::time::sleep(std::time::Duration::from_millis(200)).await;
        answer = client
            .process(ControlWord(last), &sw1, 1)
            .await
            .map_err(|e| failed(&e))?;
        outln!(
            "    t = {:>5} ms  ZSW 0x{:04X}  IW1 0x{:04X} = {:>5} % = {:>5} Hz of P105 50 Hz",
            ms(),
            answer.status().0,
            iw1(&answer),
            trim_float(nord::percent_from_word(iw1(&answer)), 2),
            trim_float(nord::word_to_physical(iw1(&answer), 50.0), 2)
        )?;
    }
    if answer.status().0 != 0x0B37 || iw1(&answer) != 0x2000 {
        return Err(failed(&format!(
            "the simulated drive did not reach the manual's 0B37h / 2000h (0x{:04X} / 0x{:04X})",
            answer.status().0,
            iw1(&answer)
        )));
    }
    outln!("    ZSW 0x0B37, IW1 0x2000: 50 % reached, as in the manual's 5.1.2")?;
    outln!("  stop: STW 0x047E (shutdown): braking ramp (P102), then ready to switch on")?;
    for _ in 0..40 {
        answer = client
            .process(command::SHUTDOWN, &[0], 1)
            .await
            .map_err(|e| failed(&e))?;
        if answer.status().state() != State::OperationEnabled {
            break;
        }
        drive_core::rt::time::sleep(std::time::Duration::from_millis(200)).await;
    }
    outln!(
        "    ZSW 0x{:04X} {} (t = {} ms)",
        answer.status().0,
        state_text(answer.status().state()),
        ms()
    )?;
    if answer.status().state() != State::ReadyToSwitchOn {
        return Err(failed(&"the simulated drive did not stop"));
    }
    let counters = *client.channel().counters();
    outln!(
        "  {} CTT2 requests, {} parameter-channel reads repeated until the answer fitted, {:.2} s \
         on the AS-i clock",
        counters.requests,
        client.repeated_requests(),
        drive_core::rt::time::elapsed(started).as_secs_f64()
    )?;
    outln!()?;
    Ok(())
}
