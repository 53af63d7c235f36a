//! The common parameter commands on a Bonfiglioli drive ([`crate::tool::cmd`]): names with
//! their data set and width, the checks before anything is sent, where a write goes (a
//! broadcast to address 0), and the variant asked of the drive where a value's meaning needs it.

use super::*;

impl cmd::Selector for Access {
    const FAMILY: Family = Family::Bonfiglioli;
    const PARAMS: &'static str = "Parameter numbers (372 or P372)";
    const PARAM: &'static str = "Parameter number";
    const INFO_PARAM: &'static str = "Parameter number (372 or P372)";
    const VOLATILE: &'static str = "Write to RAM only (data set +5: the way for values that \
        change often; lost at power-off). `--ram` is the same";
    const VOLATILE_ALIAS: Option<&'static str> = Some("ram");
    const FORCE: &'static str = "Skip the access/range/value-list/EEPROM-wear checks of the \
        table (a value that does not fit the parameter's width is never sent)";

    fn targets(params: &[String], access: Self) -> Result<Vec<Target>> {
        resolve_all(params, access)
    }

    fn check_info(param: &str, access: Self) -> Result<()> {
        resolve(param, access.dataset).and_then(|t| check_data_set(&t))
    }

    fn write_value(param: &str, value: &str, access: Self, how: &ValueText) -> Result<WriteValue> {
        write_value(param, value, access, how)
    }
}

/// `--yes` of `drivectl bonfiglioli write`.
#[derive(Debug, Clone, Copy, Args)]
pub struct Yes {
    /// Confirm a write of the drive's link settings (10 baud rate, 395 protocol type, 413
    /// watchdog, 1375 parity, 1376 address).
    #[arg(long)]
    yes: bool,
}

impl cmd::Confirm for Yes {
    fn yes(&self) -> bool {
        self.yes
    }
}

/// Refuse a parameter without a data type when neither `--word` nor `--long` was given.
pub fn check_width_known(t: &Target, given: Option<Width>) -> Result<()> {
    if table_width(t, given).is_some() {
        return Ok(());
    }
    Err(CliError::usage(drive_client::bonfiglioli::unknown_width(
        t, &Cli,
    )))
}

/// The client of the drive at `address` behind `driver` on `port` (`width`: `--word` or
/// `--long`), its messages in the command line's words.
pub fn client<'a, IO: CharIo>(
    driver: &'a mut MasterDriver<IO>,
    address: Address,
    port: &str,
    width: Option<Width>,
) -> BonfiglioliClient<'a, IO> {
    BonfiglioliClient::new(driver, address, port, width).with_front_end(&Cli)
}

/// Resolve a parameter number (`372`, `P372`) in `dataset`; numbers outside the table are
/// allowed raw (0–1599).
pub fn resolve(key: &str, dataset: u8) -> Result<Target> {
    let mut t = Target::resolve(Family::Bonfiglioli, key, RAW_INDICES)?;
    t.sub = u16::from(dataset);
    Ok(t)
}

pub fn resolve_all(params: &[String], access: Access) -> Result<Vec<Target>> {
    params
        .iter()
        .map(|p| {
            let t = resolve(p, access.dataset)?;
            check_data_set(&t)?;
            check_width_known(&t, access.width())?;
            Ok(t)
        })
        .collect()
}

/// Refuse a data set the parameter does not have, before anything is sent: a parameter that
/// exists once (the table's data-set flag, ch. 11) has data set 0 and, for a RAM-only write,
/// 5; the RAM parameters 410, 484 and 524 are always data set 0 (ch. 7). Parameters whose
/// data sets the manual does not state, and numbers outside the table, are left to the drive.
pub fn check_data_set(t: &Target) -> Result<()> {
    let Some(p) = t.param.and(bonfiglioli::by_index(t.index)) else {
        return Ok(());
    };
    let name = format!("{} {}", p.number, p.name_en);
    if p.ram_only && t.sub != 0 {
        return Err(CliError::usage(format!(
            "{name} is kept in RAM and always addressed as data set 0 (manual ch. 7): \
             --dataset {} is refused before anything is sent; leave --dataset out",
            t.sub
        )));
    }
    if p.data_set == Some(false) && !matches!(t.sub, 0 | 5) {
        let ram = if p.is_writable() {
            " (--volatile writes it to RAM only, data set 5)"
        } else {
            ""
        };
        return Err(CliError::usage(format!(
            "{name} exists once, without data sets (manual ch. 7, 11): --dataset {} is \
             refused before anything is sent; leave --dataset out{ram}",
            t.sub
        )));
    }
    Ok(())
}

/// A write to every drive (address 0): checked as any write (width, table, link settings,
/// EEPROM wear under the broadcast's own key), sent once, never answered, so nothing is read
/// back (ch. 6.1).
pub async fn write_broadcast<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    port: &str,
    request: &write::WriteRequest,
    width: Option<Width>,
    yes: bool,
    json: bool,
) -> Result<()> {
    // Keep the line quiet for the broadcast's hold and the frame gap before this process lets
    // go of the port: the next request (perhaps from the next drivectl run, a few ms later)
    // must not follow sooner, or the drives take both frames for one and drop it.
    let hold = bonfiglioli_modbus::master::BROADCAST_HOLD + m.config().line.char_times(7, 2);
    let send = async |c: &mut BonfiglioliClient<'_, IO>| {
        c.write(&request.target, request.raw, request.persistence)
            .await
            .map_err(|e| request.target.error(e))?;
        tokio::time::sleep(hold).await;
        Ok(())
    };
    let mut c = client(m, Address::BROADCAST, port, width);
    write::unanswered(&mut c, request, yes, send).await?;
    let t = request.target;
    if json {
        outln!(
            "{}",
            serde_json::json!({"parameter": t.index, "dataset": t.sub, "index": t.index,
                   "number": t.param.map(|p| p.label().to_string()),
                   "name_en": t.param.map(|p| p.name_en()),
                   "raw": request.raw, "address": 0, "answered": false})
        )
    } else {
        outln!(
            "sent {} = raw {} to every drive (broadcast, address 0; never answered by design)",
            t.label(),
            request.raw
        )
    }
}

#[allow(clippy::fn_params_excessive_bools)]
pub fn write_value(
    param: &str,
    value: &str,
    access: Access,
    how: &ValueText,
) -> Result<WriteValue> {
    let t = resolve(param, access.dataset)?;
    check_data_set(&t)?;
    check_width_known(&t, access.width())?;
    let parsed = t.value_from_text(value, how)?;
    t.check_width(parsed.raw)?;
    if let Some(w) = access.width()
        && data_of(w, parsed.raw).is_none()
    {
        return Err(CliError::usage(format!(
            "value {} does not fit 16 bits (--word: -32768…65535); nothing was sent",
            parsed.raw
        )));
    }
    Ok(WriteValue {
        target: t,
        raw: parsed.raw,
        rounded_from: parsed.rounded_from,
    })
}

/// The drive of `--addr` on the line, for the common commands.
pub struct Drive<'a, IO> {
    pub m: &'a mut MasterDriver<IO>,
    pub args: &'a BonfiglioliArgs,
}

impl<IO: CharIo> cmd::Drive for Drive<'_, IO> {
    type Selector = Access;
    type Confirm = Yes;
    type Client<'b>
        = BonfiglioliClient<'b, IO>
    where
        Self: 'b;

    async fn reader(&mut self, access: Access, targets: &[Target]) -> Result<Self::Client<'_>> {
        let args = self.args;
        let mut c = client(self.m, address(args.addr)?, &args.port, access.width())
            .given(given_variant(args));
        find_variant_for(&mut c, targets).await?;
        Ok(c)
    }

    fn keeper(&mut self) -> Result<Self::Client<'_>> {
        Ok(client(self.m, address(self.args.addr)?, &self.args.port, None).probing())
    }

    fn kept<'c>(c: &Self::Client<'c>)
    where
        Self: 'c,
    {
        note_probed(c.probed());
    }

    async fn writer(
        &mut self,
        a: &cmd::WriteArgs<Access, Yes>,
        request: &mut write::WriteRequest,
        json: bool,
    ) -> Result<cmd::Writer<Self::Client<'_>>> {
        let args = self.args;
        let t = &mut request.target;
        let ram_only = bonfiglioli::by_index(t.index).is_some_and(|p| p.ram_only);
        // RAM only: the data set + 5 on the wire (ch. 7), which the client sends for a
        // volatile write. The target stays the data set itself (`--dataset 7` is data set 2
        // in RAM): the manual names 5–9 for writes only, so the value is read back, and
        // shown, as data set 2, the value in use.
        if a.volatile || t.sub >= 5 || ram_only {
            request.persistence = Persistence::Volatile;
        }
        if t.sub >= 5 {
            t.sub -= 5;
        }
        let yes = a.confirm.yes;
        if args.addr == 0 {
            write_broadcast(self.m, &args.port, request, a.sel.width(), yes, json).await?;
            return Ok(cmd::Writer::Sent);
        }
        let mut c = client(self.m, address(args.addr)?, &args.port, a.sel.width())
            .reaching_with(reach_after(args, request.target.index, request.raw));
        if LINK_SETTINGS.contains(&request.target.index) && yes {
            // What the write changes for the link (nothing, when the value is the same).
            c.remember_link_setting(&request.target)
                .await
                .map_err(|e| request.target.error(e))?;
        }
        Ok(cmd::Writer::To {
            client: c,
            yes,
            note: None,
        })
    }

    async fn info(&mut self, a: &cmd::InfoArgs<Access>) -> Result<drive_client::info::Info> {
        info(self.m, self.args, &a.param, a.sel).await
    }
}

/// Find the drive's variant before `targets` are read when one of them is the status word 411,
/// whose meaning depends on it (the drive is asked only for `--variant auto`).
pub async fn find_variant_for<IO: CharIo>(
    c: &mut BonfiglioliClient<'_, IO>,
    targets: &[Target],
) -> Result<()> {
    if targets.iter().any(|t| t.index == param::STATUS_WORD) {
        let found = c.find_variant().await.map_err(|e| {
            CliError::failed(format!(
                "finding out whether the drive is an ACT or an ACU: {}",
                CliError::from(e)
            ))
        })?;
        say_found(&found);
    }
    Ok(())
}
