//! The address byte (ADR) of a telegram (manual ch. 4.2, "Adressierung").

use core::fmt;

/// A valid MOVILINK address; values 200–252 cannot be constructed.
///
/// | value | meaning |
/// |---|---|
/// | 0–99 | unicast: one drive, which answers |
/// | 100 | group "none" (P811 = 100: the drive belongs to no group); reaches nobody |
/// | 101–199 | group (multicast): no drive answers |
/// | 253 | local address: IPOSplus® `MOVLNK` inside one device only |
/// | 254 | point-to-point: every drive answers, so only on point-to-point links |
/// | 255 | broadcast: all drives, none answers |
///
/// ```
/// use movilink::Address;
/// assert!(Address::new(7).unwrap().expects_response());
/// assert!(!Address::BROADCAST.expects_response());
/// assert_eq!(Address::new(200), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Address(u8);

/// The kind of an [`Address`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AddressKind {
    /// 0–99: one drive.
    Unicast,
    /// 100: "no group" (P811 default), addresses nobody.
    NoGroup,
    /// 101–199: a group of drives.
    Group,
    /// 253: device-internal communication (IPOSplus® as master).
    Local,
    /// 254: point-to-point, every drive answers.
    PointToPoint,
    /// 255: all drives, none answers.
    Broadcast,
}

impl Address {
    /// Group address 100: "assigned to no group".
    pub const NO_GROUP: Self = Self(100);
    /// Local address 253.
    pub const LOCAL: Self = Self(253);
    /// Point-to-point address 254.
    pub const POINT_TO_POINT: Self = Self(254);
    /// Broadcast address 255.
    pub const BROADCAST: Self = Self(255);

    /// The address `value`, or `None` for the unused range 200–252.
    pub const fn new(value: u8) -> Option<Self> {
        match value {
            200..=252 => None,
            v => Some(Self(v)),
        }
    }

    /// The unicast address `value` (0–99), else `None`.
    pub const fn unicast(value: u8) -> Option<Self> {
        if value <= 99 { Some(Self(value)) } else { None }
    }

    /// The group address `value` (100–199), else `None`.
    pub const fn group(value: u8) -> Option<Self> {
        if value >= 100 && value <= 199 {
            Some(Self(value))
        } else {
            None
        }
    }

    /// The raw byte.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// The kind of address.
    pub const fn kind(self) -> AddressKind {
        match self.0 {
            0..=99 => AddressKind::Unicast,
            100 => AddressKind::NoGroup,
            101..=199 => AddressKind::Group,
            253 => AddressKind::Local,
            254 => AddressKind::PointToPoint,
            _ => AddressKind::Broadcast,
        }
    }

    /// 0–99.
    pub const fn is_unicast(self) -> bool {
        self.0 <= 99
    }

    /// 100–199 (including 100, "no group").
    pub const fn is_group(self) -> bool {
        self.0 >= 100 && self.0 <= 199
    }

    /// 255.
    pub const fn is_broadcast(self) -> bool {
        self.0 == 255
    }

    /// 254.
    pub const fn is_point_to_point(self) -> bool {
        self.0 == 254
    }

    /// Whether a drive answers a request to this address: false for groups (100–199) and
    /// broadcast (255), true for unicast, local and point-to-point.
    pub const fn expects_response(self) -> bool {
        !(self.is_group() || self.is_broadcast())
    }
}

impl TryFrom<u8> for Address {
    type Error = crate::DecodeError;

    fn try_from(value: u8) -> Result<Self, Self::Error> {
        Address::new(value).ok_or(crate::DecodeError::InvalidAddress { address: value })
    }
}

impl From<Address> for u8 {
    fn from(a: Address) -> u8 {
        a.0
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        for v in 0..=255u8 {
            let a = Address::new(v);
            assert_eq!(a.is_none(), (200..=252).contains(&v), "{v}");
            if let Some(a) = a {
                assert_eq!(a.get(), v);
                assert_eq!(a.expects_response(), !(100..=199).contains(&v) && v != 255);
            }
        }
        assert_eq!(
            Address::new(0).map(Address::kind),
            Some(AddressKind::Unicast)
        );
        assert_eq!(Address::NO_GROUP.kind(), AddressKind::NoGroup);
        assert_eq!(
            Address::new(150).map(Address::kind),
            Some(AddressKind::Group)
        );
        assert_eq!(Address::LOCAL.kind(), AddressKind::Local);
        assert_eq!(Address::POINT_TO_POINT.kind(), AddressKind::PointToPoint);
        assert_eq!(Address::BROADCAST.kind(), AddressKind::Broadcast);
        assert!(Address::LOCAL.expects_response());
        assert_eq!(Address::unicast(100), None);
        assert_eq!(Address::group(99), None);
        assert_eq!(Address::group(200), None);
        assert!(Address::try_from(201).is_err());
    }
}
