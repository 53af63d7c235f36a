//! `status`: the status word 411 decoded for the drive's variant, the fault 260 and the
//! warnings 270.

use super::*;

pub use drive_client::status::bits_text;

/// `status`: 411, 260 and 270 with their meanings ([`crate::tool::meaning`]), 411 for the
/// drive's variant (`None`: neither given nor shown by the drive; decoded for what both share).
pub async fn status<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    variant: Option<KnownVariant>,
    json: bool,
) -> Result<()> {
    let st = drive_client::status::bonfiglioli(m, addr, variant, &Cli)
        .await
        .map_err(|f| f.target.error(f.error))?;
    let word = st.status_word;
    if st.contradicted() {
        errln!(
            "drivectl: warning: status word 411 = 0x{word:04X} has bit 4 set, which an ACT never \
             sets (manual ch. 9.1.3): the drive looks like an ACTIVE Cube; --variant acu decodes \
             it as one"
        );
    }
    if json {
        return outln!("{}", st.json());
    }
    let text = |m: Option<crate::tool::meaning::Meaning>| m.map_or_else(String::new, |m| m.text);
    outln!("status word 411: 0x{word:04X} = {}", text(st.status()))?;
    outln!("current fault 260: {}", text(st.fault_meaning()))?;
    outln!(
        "warnings 270: 0x{:04X} = {}",
        st.warnings,
        text(st.warnings_meaning())
    )
}
