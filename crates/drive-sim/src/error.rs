//! The simulator's typed errors, which protocol front-ends map onto their own return codes.

/// Why the simulated drive refused a parameter access or a command.
///
/// Protocol front-ends translate these into their wire answers, for example MOVILINK additional
/// codes (`0x10` unknown index, `0x12` read-only, `0x13` parameter lock, `0x15`/`0x16` too
/// large/small, `0x1C` controller inhibit needed, `0x1D` value not allowed, `0x1F` not stored in
/// EEPROM, `0x20` not while the output stage is enabled), USS error numbers or Bonfiglioli
/// VABus error register values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// No parameter has this bus index.
    #[error("unknown parameter index {index}")]
    UnknownIndex {
        /// The bus index asked for.
        index: u16,
    },
    /// The parameter exists but not with this sub-index (array element or data set).
    #[error("parameter {index} has no sub-index {sub}")]
    UnknownSubIndex {
        /// The bus index.
        index: u16,
        /// The sub-index asked for.
        sub: u16,
    },
    /// The parameter is read-only.
    #[error("parameter {index} is read-only")]
    ReadOnly {
        /// The bus index.
        index: u16,
    },
    /// The value is above the parameter's range.
    #[error("value for parameter {index} is too large (maximum {max})")]
    TooLarge {
        /// The bus index.
        index: u16,
        /// The largest raw value allowed.
        max: i64,
    },
    /// The value is below the parameter's range.
    #[error("value for parameter {index} is too small (minimum {min})")]
    TooSmall {
        /// The bus index.
        index: u16,
        /// The smallest raw value allowed.
        min: i64,
    },
    /// The parameter has an exhaustive value list and the value is not in it.
    #[error("value {value} is not allowed for parameter {index}")]
    ValueNotAllowed {
        /// The bus index.
        index: u16,
        /// The rejected raw value.
        value: i64,
    },
    /// The parameter (access flag `R`) can only be written under controller inhibit.
    #[error("parameter {index} needs controller inhibit to be written")]
    NeedsInhibit {
        /// The bus index.
        index: u16,
    },
    /// The parameter cannot be written while the drive is in operation (output stage on).
    #[error("parameter {index} cannot be written while the drive is in operation")]
    NotInOperation {
        /// The bus index.
        index: u16,
    },
    /// The parameter lock is active and the parameter lacks the `S` flag.
    #[error("parameter lock is active, parameter {index} cannot be written")]
    Locked {
        /// The bus index.
        index: u16,
    },
    /// A data-set parameter was read with data set 0 while its data sets hold different values.
    #[error("the data sets of parameter {index} hold different values")]
    DataSetsDiffer {
        /// The bus index.
        index: u16,
    },
    /// The EEPROM cell has reached its configured write endurance; the value was not stored
    /// (the RAM value was not changed either).
    #[error("parameter {index} was not stored: EEPROM worn out after {writes} writes")]
    EepromWornOut {
        /// The bus index.
        index: u16,
        /// Non-volatile writes the cell has seen.
        writes: u64,
    },
    /// A command other than fault reset or inhibit was given while the drive is in fault.
    #[error("drive is in fault {code}, reset the fault first")]
    Faulted {
        /// The active fault code.
        code: u16,
    },
    /// The speed setpoint is NaN or infinite.
    #[error("speed setpoint is not a finite number")]
    InvalidSetpoint,
}
