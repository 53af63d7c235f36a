//! `info`: what the table knows of a parameter and the drive's value in each data set it has.

use super::*;

/// `info`: what the table knows of one parameter (range, default, unit, decimals, data type
/// and width, data sets, access, RAM-only) and the drive's value in each data set it has (1–4
/// for a data-set parameter, else 0; only `--dataset N` when given). The JSON keys are those of
/// `drivectl movilink info --json` where they mean the same (`index`, `number`, `name_de`,
/// `name_en`, `unit`, `range`, `default`, `default_value`, `access`), the table's columns as
/// `drivectl params bonfiglioli --json` names them, and `current`: one value object per data
/// set as `read --json` prints it, or `{label, selector, error}` for a refused one. A width the
/// manual does not give is found by trying (FC 3, then FC 100) unless --word/--long gives it.
pub async fn info<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    args: &BonfiglioliArgs,
    key: &str,
    access: Access,
) -> Result<drive_client::info::Info> {
    let t = resolve(key, access.dataset)?;
    check_data_set(&t)?;
    let table = t.param.and(bonfiglioli::by_index(t.index));
    let subs: Vec<u16> = match table {
        _ if access.dataset != 0 => vec![u16::from(access.dataset)],
        Some(p) if p.is_data_set() => vec![1, 2, 3, 4],
        _ => vec![0],
    };
    let mut c =
        client(m, address(args.addr)?, &args.port, access.width()).given(given_variant(args));
    let probing = table_width(&t, access.width()).is_none();
    if probing {
        c = c.probing();
    }
    find_variant_for(&mut c, &[t]).await?;
    drive_client::info::bonfiglioli(&mut c, t, &subs)
        .await
        .map_err(|f| f.target.error(f.error))
}
