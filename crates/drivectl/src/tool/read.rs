//! `read` of one or more parameters, for every family.

use super::client::{ClientError, ParamClient, Target};
use super::output::print_value_in;
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;

/// Read `targets` (all resolved before anything is sent) in the order given and print one
/// line or JSON object each. A drive's refusal of one parameter is reported for it on
/// standard error and the others are still read; the command then fails at the end, naming
/// what could not be read. A link failure (no answer) stops at once.
pub async fn read_all<C: ParamClient>(
    client: &mut C,
    targets: &[Target],
    json: bool,
) -> Result<()> {
    if let [t] = targets {
        let raw = client.read(t).await.map_err(|e| t.error(e))?;
        return print_value_in(t, raw, json, &client.device());
    }
    let mut refused = Vec::new();
    for (i, t) in targets.iter().enumerate() {
        match client.read(t).await {
            Ok(raw) => print_value_in(t, raw, json, &client.device())?,
            Err(ClientError::Device(d)) => {
                errln!("drivectl: {}: {d}", t.label());
                refused.push(t.label());
            }
            // The link failed (or a failure this drivectl does not know yet): stop reading.
            Err(m) => {
                let unread: Vec<String> = targets.iter().skip(i).map(Target::label).collect();
                return Err(CliError::failed(format!(
                    "{}: {m}; not read: {}",
                    t.label(),
                    unread.join(", ")
                )));
            }
        }
    }
    if refused.is_empty() {
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "{} of {} parameters could not be read: {} (the drive's answers are above)",
            refused.len(),
            targets.len(),
            refused.join(", ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::client::DeviceErrorKind;
    use crate::tool::fake::{FakeClient, refusal};
    use drive_profile::Family;

    fn targets(keys: &[&str]) -> Vec<Target> {
        keys.iter()
            .map(|k| Target::resolve(Family::Movidrive, k, 1000..=0xFFFF).unwrap())
            .collect()
    }

    fn drive(index: u16) -> std::result::Result<i64, ClientError> {
        match index {
            8470 => Err(refusal(DeviceErrorKind::Refused, "parameter lock")),
            9999 => Err(ClientError::link(
                drive_client::LinkFault::NoAnswer,
                "no answer",
            )),
            _ => Ok(0),
        }
    }

    #[tokio::test]
    async fn a_refusal_is_named_at_the_end_and_a_link_failure_stops() {
        let mut c = FakeClient::new(drive);
        let e = read_all(&mut c, &targets(&["P000", "P130", "P002"]), true)
            .await
            .unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert_eq!(
            e.to_string(),
            "1 of 3 parameters could not be read: P130 (the drive's answers are above)"
        );
        let e = read_all(&mut c, &targets(&["P000", "9999", "P002"]), true)
            .await
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "index 9999: no answer; not read: index 9999, P002"
        );
        read_all(&mut c, &targets(&["P000", "P002"]), true)
            .await
            .unwrap();
    }
}
