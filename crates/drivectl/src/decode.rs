//! What the decoders and `info` share with `read --json`: the parameter a telegram or a
//! description names, in the keys of `tool::output::value_json`.

use serde_json::Value;

use crate::tool::client::Target;
use crate::tool::output::value_json;

/// The parameter keys of `read --json` (`tool::output::value_json`) for `t`; without a value
/// (`raw` = `None`: a read request, a refusal) `raw`, `value`, `meaning` and `decoded` are
/// `null`.
pub fn param_json(t: &Target, raw: Option<i64>) -> Value {
    let mut v = value_json(t, raw.unwrap_or(0));
    if raw.is_none()
        && let Value::Object(m) = &mut v
    {
        for k in ["raw", "value", "meaning", "decoded"] {
            m.insert(k.into(), Value::Null);
        }
    }
    v
}
