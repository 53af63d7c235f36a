//! What `drivectl movilink` and `drivectl sbus` share: a MOVIDRIVE's parameter channel is the
//! same on RS-485 and on CAN (the same services, return codes and parameter table), so the
//! tool layer's [`ParamClient`] for a MOVIDRIVE is written once, on [`SewLink`], and each bus
//! gives only its way to the drive: the MOVILINK master on a serial line, the SBus master on a
//! CAN interface.

use drive_profile::sew::{self, ParamChannel, ReturnCode, index};
use drive_profile::{Access, Family, Persistence};
use serde_json::{Map, Value, json};

use crate::error::Result;
use crate::tool::client::{ClientError, DeviceError, DeviceErrorKind, ParamClient, Target};
use crate::tool::output::physical_text;

/// One MOVIDRIVE's parameter channel over some bus.
pub trait SewLink {
    /// Run `request` (a parameter service) on the drive: the answer's data, a refusal of the
    /// drive ([`device_error`]) or a link failure.
    async fn service(&mut self, request: ParamChannel) -> std::result::Result<u32, ClientError>;

    /// The bus the drive is on, for the EEPROM-wear log: a serial port's or CAN interface's
    /// canonical name (see `tool::client::canonical_port`).
    fn bus_key(&self) -> String;

    /// The drive's own address for the EEPROM-wear log (a point-to-point address is resolved
    /// by asking the drive).
    async fn drive_address(&mut self) -> std::result::Result<String, ClientError>;

    /// Indices of the drive's settings for this bus (address, timeouts): writing one needs
    /// confirmation.
    fn link_settings(&self) -> &'static [u16];

    /// Indices a restore over this bus never writes.
    fn not_restored(&self) -> &'static [u16];

    /// What writing `raw` to the link setting `target` does, for a person.
    fn link_change(&self, target: &Target, raw: i64) -> String;

    /// The link setting `target` was written with `raw`: follow it where possible.
    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        self.link_change(target, raw)
    }

    /// The drive's address as a number, for `identify`.
    fn address_number(&self) -> u8;

    /// Bytes the bus's driver discarded as stale so far (see [`ParamClient::stale_bytes`]).
    fn stale_bytes(&self) -> u64 {
        0
    }
}

/// The tool layer's client for a MOVIDRIVE on any [`SewLink`].
#[derive(Debug)]
pub struct SewClient<L> {
    /// The way to the drive.
    pub link: L,
    /// The drive's key for the EEPROM-wear log, once known.
    key: Option<String>,
}

impl<L> SewClient<L> {
    /// The client of the drive behind `link`.
    pub fn new(link: L) -> Self {
        Self { link, key: None }
    }
}

/// How often a service answered with "internal communication error" (6/2) is sent in all: the
/// manual says to repeat it, and to power-cycle the drive when it persists.
pub const SERVICE_ATTEMPTS: u32 = 3;

/// What a SEW return code means for the tool layer.
pub fn device_error_kind(code: ReturnCode) -> DeviceErrorKind {
    if [
        ReturnCode::ILLEGAL_INDEX,
        ReturnCode::NOT_IMPLEMENTED,
        ReturnCode::OPTION_CARD_MISSING,
    ]
    .contains(&code)
    {
        DeviceErrorKind::Absent
    } else if (code.error_class, code.error_code) == (6, 2) {
        DeviceErrorKind::Transient
    } else {
        DeviceErrorKind::Refused
    }
}

/// The tool layer's error of a drive's refusal `code`, with `message` for a person.
pub fn device_error(code: ReturnCode, message: String) -> ClientError {
    ClientError::Device(DeviceError {
        kind: device_error_kind(code),
        message,
    })
}

/// The 32-bit data of a raw value (it has passed the width check: signed or unsigned 32 bits).
pub fn data_of(raw: i64) -> u32 {
    raw as u32
}

/// A raw value of 32-bit data: signed where the parameter's range goes below zero, else
/// unsigned (as the drive reads it); signed outside the table.
pub fn raw_of(t: &Target, data: u32) -> i64 {
    match t.param.map(|p| p.wire_range()) {
        Some((lo, _)) if lo >= 0 => i64::from(data),
        _ => i64::from(data as i32),
    }
}

impl<L: SewLink> SewClient<L> {
    /// `request`, repeated while the drive answers "internal communication error".
    async fn service(&mut self, request: ParamChannel) -> std::result::Result<u32, ClientError> {
        let mut attempts = 0;
        loop {
            attempts += 1;
            match self.link.service(request).await {
                // The manual: "repeat the read or write service".
                Err(ClientError::Device(d))
                    if d.kind == DeviceErrorKind::Transient && attempts < SERVICE_ATTEMPTS => {}
                done => return done,
            }
        }
    }
}

impl<L: SewLink> ParamClient for SewClient<L> {
    fn family(&self) -> Family {
        Family::Movidrive
    }

    async fn drive_key(&mut self) -> std::result::Result<String, ClientError> {
        if let Some(k) = &self.key {
            return Ok(k.clone());
        }
        let address = self.link.drive_address().await?;
        let key = format!("{} {address}", self.link.bus_key());
        self.key = Some(key.clone());
        Ok(key)
    }

    fn link_settings(&self) -> &'static [u16] {
        self.link.link_settings()
    }

    fn stale_bytes(&self) -> u64 {
        self.link.stale_bytes()
    }

    fn link_change(&self, target: &Target, raw: i64) -> String {
        self.link.link_change(target, raw)
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        let before = self.link.address_number();
        let note = self.link.follow_link_change(target, raw);
        if self.link.address_number() != before {
            self.key = None;
        }
        note
    }

    fn not_restored(&self) -> &'static [u16] {
        self.link.not_restored()
    }

    async fn read(&mut self, target: &Target) -> std::result::Result<i64, ClientError> {
        let data = self.service(ParamChannel::read(target.index)).await?;
        Ok(raw_of(target, data))
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> std::result::Result<(), ClientError> {
        let data = data_of(raw);
        let request = match persistence {
            Persistence::Volatile => ParamChannel::write_volatile(target.index, data),
            Persistence::NonVolatile => ParamChannel::write(target.index, data),
        };
        self.service(request).await.map(drop)
    }

    async fn identify(&mut self) -> std::result::Result<Map<String, Value>, ClientError> {
        let device_type = self.service(ParamChannel::read(index::UNIT_TYPE)).await?;
        let firmware = self.service(ParamChannel::read(index::FIRMWARE)).await?;
        let mut m = Map::new();
        m.insert("address".into(), self.link.address_number().into());
        m.insert("device_type".into(), device_type.into());
        m.insert("firmware".into(), firmware.into());
        Ok(m)
    }
}

/// `info`: minimum, maximum, default, scale and attributes of `t`.
pub async fn info<L: SewLink>(link: &mut L, t: Target, json: bool) -> Result<()> {
    let min = link.service(ParamChannel::read_minimum(t.index)).await?;
    let max = link.service(ParamChannel::read_maximum(t.index)).await?;
    let default = link.service(ParamChannel::read_default(t.index)).await?;
    let scale = sew::ScaleInfo::from_data(link.service(ParamChannel::read_scale(t.index)).await?);
    let attr =
        sew::AttributeInfo::from_data(link.service(ParamChannel::read_attribute(t.index)).await?);
    let access = Access::from_bits_truncate(attr.attributes as u8);
    // The drive's value too, as `read` shows it (the key `current` of every family's `info`).
    let current = raw_of(&t, link.service(ParamChannel::read(t.index)).await?);
    let show = |data: u32| {
        let v = raw_of(&t, data);
        t.param
            .map_or_else(|| v.to_string(), |p| physical_text(p, v))
    };
    let size_name = sew::size_name(scale.size_index).unwrap_or("unknown quantity");
    let physical = |raw: i64| t.param.map_or(raw as f64, |p| p.to_physical(raw));
    if json {
        outln!(
            "{}",
            crate::tool::output::info_json(
                &t,
                json!({
                    // The keys of `params … --json` where they mean the same: raw values plain,
                    // physical ones as `*_value` in the table's unit.
                    "range": {
                        "min": raw_of(&t, min), "max": raw_of(&t, max),
                        "min_value": physical(raw_of(&t, min)), "max_value": physical(raw_of(&t, max)),
                    },
                    "default": raw_of(&t, default), "default_value": physical(raw_of(&t, default)),
                    "size_index": scale.size_index, "conversion_index": scale.conversion_index,
                    "quantity": size_name,
                    "next_index": attr.next_index, "attributes": attr.attributes, "access": access.to_string(),
                    "current": [crate::tool::output::value_json(&t, current)],
                })
            )
        )?;
    } else {
        let name = t
            .param
            .map_or_else(String::new, |p| format!("{} {} ", p.label(), p.name_en()));
        outln!("{name}(index {})", t.index)?;
        outln!(
            "  value      {}",
            crate::tool::output::value_text(&t, current)
        )?;
        outln!("  minimum    {}", show(min))?;
        outln!("  maximum    {}", show(max))?;
        outln!("  default    {}", show(default))?;
        outln!(
            "  scale      size index {} ({size_name}), conversion index {}",
            scale.size_index,
            scale.conversion_index
        )?;
        outln!(
            "  attributes 0x{:04X} ({access}), next index {}",
            attr.attributes,
            attr.next_index
        )?;
    }
    Ok(())
}

/// `read`: every name resolved first (a mistyped one is an error before anything is sent),
/// then one line (or JSON object) per parameter.
pub async fn read<L: SewLink>(link: L, params: &[String], json: bool) -> Result<()> {
    let targets = resolve_all(params)?;
    crate::tool::read::read_all(&mut SewClient::new(link), &targets, json).await
}

/// `watch`: the parameters polled at a steady rhythm until `--count` or Ctrl-C.
pub async fn watch<L: SewLink>(
    link: L,
    params: &[String],
    args: &crate::tool::watch::WatchArgs,
    json: bool,
) -> Result<()> {
    use crate::tool::watch;
    let targets = resolve_all(params)?;
    let options = args.options(json)?;
    watch::watch(
        &mut SewClient::new(link),
        &targets,
        options,
        &mut |s| out!("{s}"),
        watch::ctrl_c(),
    )
    .await
    .map(drop)
}

fn resolve_all(params: &[String]) -> Result<Vec<Target>> {
    params.iter().map(|p| crate::movilink::resolve(p)).collect()
}

/// What `write` was given on the command line.
#[derive(Debug, Clone, Copy)]
pub struct WriteText<'a> {
    /// Index or menu number.
    pub param: &'a str,
    /// The value as typed.
    pub value: &'a str,
    /// `--raw`.
    pub raw: bool,
    /// `--volatile`.
    pub volatile: bool,
    /// `--force`.
    pub force: bool,
    /// `--round`.
    pub round: bool,
}

/// The checked write request of `write`'s options; a rounded value is said.
pub fn write_request(w: WriteText<'_>) -> Result<crate::tool::write::WriteRequest> {
    let t = crate::movilink::resolve(w.param)?;
    let how = crate::tool::client::ValueText {
        raw: w.raw,
        force: w.force,
        round: w.round,
    };
    let parsed = t.value_from_text(w.value, &how)?;
    if let (Some(x), Some(p)) = (parsed.rounded_from, t.param) {
        errln!(
            "drivectl: note: {} cannot hold {x} exactly; writing the nearest value it takes, {}",
            p.label(),
            physical_text(p, parsed.raw)
        );
    }
    Ok(crate::tool::write::WriteRequest {
        target: t,
        raw: parsed.raw,
        persistence: if w.volatile {
            Persistence::Volatile
        } else {
            Persistence::NonVolatile
        },
        force: w.force,
    })
}

/// `write` to one drive: the one write path (checks, wear log, read-back at the followed
/// address), then the value as read back.
pub async fn write<L: SewLink>(
    link: L,
    request: &crate::tool::write::WriteRequest,
    yes: bool,
    json: bool,
) -> Result<()> {
    let done = crate::tool::write::write_checked(&mut SewClient::new(link), request, yes).await?;
    crate::tool::write::print_written(&request.target, &done, json)
}

/// Where an unanswered write goes, for the output: the text (`group 2`, `broadcast`) and the
/// JSON key and number (`"group": 2`, `"address": 255`).
#[derive(Debug, Clone)]
pub struct Unanswered {
    /// For a person.
    pub text: String,
    /// The JSON key.
    pub key: &'static str,
    /// The number under it.
    pub number: u8,
}

/// A write that every drive addressed executes and none answers (a group, a broadcast): the
/// same checks and wear log as an answered write, then `send` puts it on the bus; there is
/// nothing to read back. The drives of a group share the wear-log entry of the group.
pub async fn write_unanswered<L, F>(
    link: L,
    request: &crate::tool::write::WriteRequest,
    yes: bool,
    json: bool,
    to: Unanswered,
    send: F,
) -> Result<()>
where
    L: SewLink,
    F: AsyncFnOnce(&mut L, ParamChannel) -> Result<()>,
{
    use crate::tool::write;
    let mut client = SewClient::new(link);
    write::check_link_setting(&client, request, yes)?;
    let drive_key = client.drive_key().await?;
    if let Some(warning) = write::check(&mut client, request).await? {
        errln!("drivectl: warning: {warning}");
    }
    let t = request.target;
    let data = data_of(request.raw);
    let channel = match request.persistence {
        Persistence::Volatile => ParamChannel::write_volatile(t.index, data),
        Persistence::NonVolatile => ParamChannel::write(t.index, data),
    };
    send(&mut client.link, channel).await?;
    if let Err(e) = write::record(&drive_key, request) {
        errln!("drivectl: warning: {e}");
    }
    if json {
        let mut m = Map::new();
        m.insert("index".into(), t.index.into());
        m.insert(
            "number".into(),
            json!(t.param.map(|p| p.label().to_string())),
        );
        m.insert("name_de".into(), json!(t.param.map(|p| p.name_de())));
        m.insert("name_en".into(), json!(t.param.map(|p| p.name_en())));
        m.insert("raw".into(), request.raw.into());
        m.insert(to.key.into(), to.number.into());
        m.insert("answered".into(), false.into());
        outln!("{}", Value::Object(m))?;
    } else {
        outln!(
            "sent index {} = raw {} to {} (never answered by design)",
            t.index,
            request.raw,
            to.text
        )?;
    }
    Ok(())
}

/// `backup`: every readable parameter to a JSON file.
pub async fn backup<L: SewLink>(
    link: L,
    args: &crate::tool::backup::BackupArgs,
    json: bool,
) -> Result<()> {
    let stop = crate::tool::interrupt::Interrupt::install("the backup file was not written");
    crate::tool::backup::backup(
        &mut SewClient::new(link),
        &args.out,
        args.overwrite,
        json,
        &stop,
    )
    .await
}

/// `restore`: a backup file written back and verified.
pub async fn restore<L: SewLink>(
    link: L,
    args: &crate::tool::backup::RestoreArgs,
    json: bool,
) -> Result<()> {
    let stop = crate::tool::interrupt::Interrupt::install(
        "the drive may be half restored; run the same restore again to finish it",
    );
    crate::tool::backup::restore(
        &mut SewClient::new(link),
        &args.file,
        args.options(),
        json,
        &stop,
    )
    .await
}

/// Per process output word (the first `words`, at most 3): whether the drive takes it as a
/// control word (its setpoint description P870–P872 is 9, control word 1, or 10, control word
/// 2), or why the description could not be read.
pub async fn control_word_slots<L: SewLink>(
    link: &mut L,
    words: usize,
) -> Vec<std::result::Result<bool, ClientError>> {
    let mut slots = Vec::new();
    for i in [index::PO1_DESCRIPTION, 8305, 8306].into_iter().take(words) {
        slots.push(
            link.service(ParamChannel::read(i))
                .await
                .map(|d| matches!(d, 9 | 10)),
        );
    }
    slots
}

/// `words` with the command `cmd` in the low byte of every control word slot (its high byte
/// kept): the stop telegram at the end of process data.
pub fn with_command(
    words: &[u16],
    slots: &[usize],
    cmd: drive_profile::sew::ControlWord1,
) -> Vec<u16> {
    let mut w = words.to_vec();
    for &i in slots {
        if let Some(x) = w.get_mut(i) {
            *x = (*x & 0xFF00) | cmd.bits();
        }
    }
    w
}

/// Before process data: the control word slots among the process output words, and the
/// warnings a person should see: no control word (when `stopping`: the drive cannot be stopped
/// over process data at the end), the bus's timeout (`timeout`: P812 RS-485, P815 SBus) 0 (off),
/// P876 PO data enable off. A parameter the drive does not answer gets a warning, not an error:
/// the session itself says what is wrong.
pub async fn pd_warnings<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
) -> (Vec<usize>, Vec<String>) {
    let mut warnings = Vec::new();
    let mut slots = Vec::new();
    for (slot, r) in control_word_slots(link, words)
        .await
        .into_iter()
        .enumerate()
    {
        match r {
            Ok(true) => slots.push(slot),
            Ok(false) => {}
            Err(e) => warnings.push(format!(
                "cannot read the setpoint description of PO{} ({})",
                slot + 1,
                client_error_text(&e)
            )),
        }
    }
    if stopping && slots.is_empty() {
        warnings.push(
            "no process output word of this drive is a control word (P870–P872): it cannot be \
             stopped over process data at the end"
                .to_owned(),
        );
    }
    let (timeout_index, timeout_name) = timeout;
    match link.service(ParamChannel::read(timeout_index)).await {
        Ok(0) => warnings.push(format!(
            "the drive's {timeout_name} is 0 (off): it keeps running when the master goes quiet{}",
            if stopping {
                ""
            } else {
                " (and --keep-running leaves it running)"
            }
        )),
        Ok(_) => {}
        Err(e) => warnings.push(format!(
            "cannot read the {timeout_name} ({})",
            client_error_text(&e)
        )),
    }
    if let Ok(0) = link
        .service(ParamChannel::read(index::PO_DATA_ENABLE))
        .await
    {
        warnings
            .push("P876 PO data enable is off: the drive ignores process output data".to_owned());
    }
    (slots, warnings)
}

/// The stop a SEW `pd` session ends with (`movilink pd`, `sbus pd`): the output words with the
/// stop command in the low byte of every control word slot, the other words as they were.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PdStop {
    /// The words sent to stop.
    pub words: Vec<u16>,
    /// The command in the control word slots.
    pub cmd: drive_profile::sew::ControlWord1,
    /// The first control word slot (for the message).
    slot: usize,
}

impl PdStop {
    /// The stop of a session sending `words` with control words in `slots`; `None` when no
    /// output word is a control word (nothing can stop the drive over process data).
    pub fn new(
        words: &[u16],
        slots: &[usize],
        cmd: drive_profile::sew::ControlWord1,
    ) -> Option<Self> {
        let slot = *slots.first()?;
        Some(Self {
            words: with_command(words, slots, cmd),
            cmd,
            slot,
        })
    }

    /// What was sent, for the guard's message: `stop (control word 0x0002)`.
    pub fn sent(&self) -> String {
        format!(
            "{} (control word 0x{:04X})",
            self.cmd.command().name(),
            self.words.get(self.slot).copied().unwrap_or(0)
        )
    }

    /// How the session ends ([`crate::tool::motor::AtEnd`]): stopped with `stop`, else left as
    /// the last exchange set it, with the reason.
    pub fn at_end(stop: Option<&PdStop>, keep_running: bool) -> crate::tool::motor::AtEnd {
        use crate::tool::motor::AtEnd;
        match (keep_running, stop) {
            (true, _) => AtEnd::KeepRunning("--keep-running"),
            (false, None) => AtEnd::KeepRunning("no process output word is a control word"),
            (false, Some(_)) => AtEnd::Stop,
        }
    }

    /// The `pd` arguments that stop the drive, for the hint (`pd --out 0x0002,5000,0`): the
    /// stop command `cmd` in the control word slots, PO1 (the factory setting's control word)
    /// where none is known.
    pub fn hint(words: &[u16], slots: &[usize], cmd: drive_profile::sew::ControlWord1) -> String {
        let slots = if slots.is_empty() { &[0][..] } else { slots };
        let w: Vec<String> = with_command(words, slots, cmd)
            .iter()
            .map(|w| format!("0x{w:04X}"))
            .collect();
        format!("pd --out {}", w.join(","))
    }
}

/// What [`pd_preflight`] found out before process data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preflight {
    /// The process output words the drive takes as control words.
    pub slots: Vec<usize>,
    /// The drive's bus timeout (P812 RS-485 / P815 SBus), `None` when it is off (0, or P815's
    /// 650 s) or could not be read.
    pub timeout: Option<std::time::Duration>,
}

/// [`pd_warnings`] with the warnings on standard error (`drivectl movilink pd`, `sbus pd`), and
/// the bus timeout the exchanges must keep fed.
pub async fn pd_preflight<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
) -> Preflight {
    let (slots, warnings) = pd_warnings(link, words, stopping, timeout).await;
    for w in warnings {
        errln!("drivectl: warning: {w}");
    }
    Preflight {
        slots,
        timeout: bus_timeout(link, timeout.0).await,
    }
}

/// The bus timeout at `index` (P812, P815: milliseconds in the drive), `None` when it is off
/// (0, and for P815 also 650 s, the manual: "no monitoring") or unreadable.
pub async fn bus_timeout<L: SewLink>(link: &mut L, index: u16) -> Option<std::time::Duration> {
    match link.service(ParamChannel::read(index)).await {
        Ok(0) => None,
        Ok(650_000) if index == index::SBUS_TIMEOUT => None,
        Ok(ms) => Some(std::time::Duration::from_millis(u64::from(ms))),
        Err(_) => None,
    }
}

/// The interval between process data exchanges: the one asked for, or by default one that
/// keeps the drive's bus timeout fed (half of it, whole `grain`s, at most `default`). An
/// interval at or above the timeout is refused: the drive would trip (`fault`, e.g. F47 SBus
/// timeout) between two exchanges.
pub fn pd_interval(
    asked: Option<u64>,
    timeout: Option<std::time::Duration>,
    default: u64,
    grain: u64,
    timeout_name: &str,
    fault: &str,
) -> Result<std::time::Duration> {
    let timeout_ms = timeout.map(|t| u64::try_from(t.as_millis()).unwrap_or(u64::MAX));
    let ms = match (asked, timeout_ms) {
        (Some(ms), Some(t)) if ms >= t => {
            let fits = (t / 2 / grain * grain).max(grain.min(t.saturating_sub(1)).max(1));
            return Err(crate::error::CliError::usage(format!(
                "--interval {ms} ms is not shorter than the drive's {timeout_name} of {t} ms: the \
                 drive would trip with {fault} between two exchanges; use --interval {fits} or \
                 less (or raise the timeout)"
            )));
        }
        (Some(ms), _) => ms,
        (None, Some(t)) => (t / 2 / grain * grain).clamp(grain, default.max(grain)),
        (None, None) => default,
    };
    Ok(std::time::Duration::from_millis(ms))
}

fn client_error_text(e: &ClientError) -> &str {
    match e {
        ClientError::Device(d) => &d.message,
        ClientError::Link(m) => m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::motor::AtEnd;
    use drive_profile::sew::ControlWord1;

    #[test]
    fn the_pd_stop_goes_into_the_control_word_slots_only() {
        // PO1 control word 1 (enable), PO2 speed, PO3 another control word with its high byte.
        let words = [0x0006, 5000, 0x1206];
        let stop = PdStop::new(&words, &[0, 2], ControlWord1::STOP).unwrap();
        assert_eq!(stop.words, [0x0002, 5000, 0x1202]);
        assert_eq!(stop.sent(), "stop (control word 0x0002)");
        assert_eq!(PdStop::at_end(Some(&stop), false), AtEnd::Stop);
        // No control word: nothing stops it; --keep-running wins anyway.
        assert_eq!(PdStop::new(&words, &[], ControlWord1::STOP), None);
        assert!(matches!(
            PdStop::at_end(None, false),
            AtEnd::KeepRunning(r) if r.contains("control word")
        ));
        assert_eq!(
            PdStop::at_end(Some(&stop), true),
            AtEnd::KeepRunning("--keep-running")
        );
        // The hint: the factory setting's PO1 where no slot is known.
        assert_eq!(
            PdStop::hint(&words, &[], ControlWord1::INHIBIT),
            "pd --out 0x0001,0x1388,0x1206"
        );
    }
}
