//! Slave addresses and the start address (data set and parameter number).

use core::fmt;

/// A Modbus slave address (ch. 6.2): 1–247 a single drive, 0 broadcast (write-only, never
/// answered). 248–255 are reserved and cannot be constructed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Address(u8);

impl Address {
    /// Broadcast: every drive executes the write, none answers.
    pub const BROADCAST: Address = Address(0);

    /// The address `a`, if it is 0–247.
    pub const fn new(a: u8) -> Option<Address> {
        if a <= 247 { Some(Address(a)) } else { None }
    }

    /// The address as a number.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// Address 0.
    pub const fn is_broadcast(self) -> bool {
        self.0 == 0
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_broadcast() {
            f.write_str("broadcast (0)")
        } else {
            write!(f, "{}", self.0)
        }
    }
}

/// A data set (ch. 7): 0 all four at once, 1–4 one of them (RAM and EEPROM), 5–9 the RAM-only
/// twins of 0–4 (for cyclic writes that must not wear the EEPROM).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DataSet(u8);

impl DataSet {
    /// Data set 0: a write sets data sets 1–4; a read fails (VABus error 9) when they differ.
    pub const ALL: DataSet = DataSet(0);

    /// Data set `d`, if it is 0–9.
    pub const fn new(d: u8) -> Option<DataSet> {
        if d <= 9 { Some(DataSet(d)) } else { None }
    }

    /// The number 0–9.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// 5–9: written to RAM only.
    pub const fn is_ram_only(self) -> bool {
        self.0 >= 5
    }

    /// The data set a RAM-only one stands for (5 → 0, …, 9 → 4); itself for 0–4.
    pub const fn stored(self) -> DataSet {
        if self.0 >= 5 {
            DataSet(self.0 - 5)
        } else {
            self
        }
    }

    /// The RAM-only twin of 0–4 (0 → 5, …); itself for 5–9.
    pub const fn ram_only(self) -> DataSet {
        if self.0 < 5 {
            DataSet(self.0 + 5)
        } else {
            self
        }
    }
}

impl fmt::Display for DataSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The 16-bit start address of a request (ch. 6.4.1): data set in bits 12–15, parameter
/// number in bits 0–11 (372 in data set 2 is 0x2174). Any 16-bit value can arrive on the wire,
/// so it is kept raw; [`StartAddress::data_set`] and [`StartAddress::param`] check the ranges
/// (data set 0–9, parameter 0–1599).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StartAddress(u16);

impl StartAddress {
    /// The largest parameter number (1599, 0x63F).
    pub const MAX_PARAM: u16 = 1599;

    /// Parameter `param` in data set `data_set`, if the parameter is 0–1599.
    pub const fn new(data_set: DataSet, param: u16) -> Option<StartAddress> {
        if param <= Self::MAX_PARAM {
            Some(StartAddress(((data_set.0 as u16) << 12) | param))
        } else {
            None
        }
    }

    /// The value on the wire, whatever it is.
    pub const fn from_raw(raw: u16) -> StartAddress {
        StartAddress(raw)
    }

    /// The value on the wire.
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// The data set of bits 12–15, if it is 0–9.
    pub const fn data_set(self) -> Option<DataSet> {
        DataSet::new((self.0 >> 12) as u8)
    }

    /// The parameter number of bits 0–11, if it is 0–1599.
    pub const fn param(self) -> Option<u16> {
        let p = self.0 & 0x0FFF;
        if p <= Self::MAX_PARAM { Some(p) } else { None }
    }

    /// Bits 0–11 as they are (up to 4095).
    pub const fn param_bits(self) -> u16 {
        self.0 & 0x0FFF
    }
}

impl fmt::Display for StartAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "parameter {} data set {} (0x{:04X})",
            self.param_bits(),
            self.0 >> 12,
            self.0
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manuals_start_address_example() {
        // Parameter 372 (0x174) in data set 2 is 0x2174 (ch. 6.4.1).
        let s = StartAddress::new(DataSet::new(2).unwrap(), 372).unwrap();
        assert_eq!(s.raw(), 0x2174);
        assert_eq!((s.data_set(), s.param()), (DataSet::new(2), Some(372)));
        // The manual's upper end 0x963F: data set 9, parameter 1599.
        let top = StartAddress::from_raw(0x963F);
        assert_eq!((top.data_set(), top.param()), (DataSet::new(9), Some(1599)));
        assert_eq!(StartAddress::from_raw(0xA000).data_set(), None);
        assert_eq!(StartAddress::from_raw(0x0640).param(), None);
        assert!(StartAddress::new(DataSet::ALL, 1600).is_none());
        assert_eq!(DataSet::new(7).unwrap().stored(), DataSet::new(2).unwrap());
        assert_eq!(DataSet::new(2).unwrap().ram_only().get(), 7);
        assert!(Address::new(248).is_none() && Address::new(247).is_some());
    }
}
