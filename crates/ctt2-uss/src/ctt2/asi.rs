//! The AS-i side of the double slave (BU 0255 sections 3.2, 3.3 and 4.4): addresses, profiles,
//! the cyclic BusIO bits, and an in-memory AS-i network with the CTT2 transfer-time model.
//!
//! * The drive is a **double slave**: two AS-i slaves with extended addressing, each with an
//!   address of its own from 1A–31A / 1B–31B ([`AsiAddress`], [`DoubleSlaveAddress`]). The 1st
//!   slave has profile S-7.A.7.7 and 4 BusIO bits each way; the 2nd has S-7.A.*.5, one more
//!   BusIO In bit, two more BusIO Out bits, and the CTT2 channel. Together: 5 In and 6 Out bits
//!   seen from the drive ([`BusIoIn`], [`BusIoOut`]); their functions are set by P480 / P481.
//! * A network has at most 62 slaves, at most 31 double slaves, and standard slaves (one
//!   whole address 1–31) mixed with extended ones ([`AsiNetwork`]).
//! * CTT2 bytes are slow: 16 × 154 µs × (2 + number of slaves) per byte (section 4.4;
//!   [`AsiNetwork::byte_time`]), 81.312 ms with 31 slaves.

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use drive_profile::nord::ctt2_byte_time_us;

/// The A or B half of an extended address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Bank {
    /// A address (1A–31A).
    A,
    /// B address (1B–31B).
    B,
}

/// An AS-i slave address with extended addressing: 1A–31A or 1B–31B.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AsiAddress {
    number: u8,
    bank: Bank,
}

impl AsiAddress {
    /// Address `number` (1–31) in `bank`; `None` outside 1–31 (0 is the address of an
    /// unaddressed slave).
    pub const fn new(number: u8, bank: Bank) -> Option<AsiAddress> {
        if number >= 1 && number <= 31 {
            Some(AsiAddress { number, bank })
        } else {
            None
        }
    }

    /// The number, 1–31.
    pub const fn number(self) -> u8 {
        self.number
    }

    /// A or B.
    pub const fn bank(self) -> Bank {
        self.bank
    }
}

impl fmt::Display for AsiAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = match self.bank {
            Bank::A => 'A',
            Bank::B => 'B',
        };
        write!(f, "{}{b}", self.number)
    }
}

impl fmt::Debug for AsiAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "AsiAddress({self})")
    }
}

/// Why a text is not an AS-i address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum AddressParseError {
    /// Not a number followed by A or B (e.g. "5A").
    #[error("an extended AS-i address is a number 1 to 31 followed by A or B (e.g. \"5A\")")]
    Syntax,
    /// A number outside 1–31.
    #[error("AS-i address {0} is outside 1 to 31")]
    OutOfRange(u8),
}

impl FromStr for AsiAddress {
    type Err = AddressParseError;

    /// "5A", "31b", " 12B " (case-insensitive, surrounding blanks ignored).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        let (digits, bank) = match s.as_bytes().last() {
            Some(b'A' | b'a') => (s.get(..s.len() - 1), Bank::A),
            Some(b'B' | b'b') => (s.get(..s.len() - 1), Bank::B),
            _ => return Err(AddressParseError::Syntax),
        };
        let digits = digits.ok_or(AddressParseError::Syntax)?;
        if digits.is_empty() || digits.len() > 3 || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(AddressParseError::Syntax);
        }
        let n: u8 = digits.parse().map_err(|_| AddressParseError::Syntax)?;
        AsiAddress::new(n, bank).ok_or(AddressParseError::OutOfRange(n))
    }
}

/// An AS-i slave profile "S-IO.ID.ID1.ID2" (hexadecimal digits; ID1 `None` = "*", any).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Profile {
    /// I/O configuration.
    pub io: u8,
    /// ID code.
    pub id: u8,
    /// Extended ID code 1 (`None`: any, "*").
    pub id1: Option<u8>,
    /// Extended ID code 2.
    pub id2: u8,
}

impl Profile {
    /// The 1st slave of the double slave: S-7.A.7.7, 4 BusIO bits each way.
    pub const FIRST: Profile = Profile {
        io: 0x7,
        id: 0xA,
        id1: Some(0x7),
        id2: 0x7,
    };

    /// The 2nd slave: S-7.A.*.5, 1 more In and 2 more Out bits and the CTT2 channel.
    pub const SECOND: Profile = Profile {
        io: 0x7,
        id: 0xA,
        id1: None,
        id2: 0x5,
    };
}

impl fmt::Display for Profile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "S-{:X}.{:X}.", self.io, self.id)?;
        match self.id1 {
            Some(x) => write!(f, "{x:X}")?,
            None => write!(f, "*")?,
        }
        write!(f, ".{:X}", self.id2)
    }
}

/// The two addresses of a double slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DoubleSlaveAddress {
    /// The 1st slave (profile S-7.A.7.7).
    pub first: AsiAddress,
    /// The 2nd slave (profile S-7.A.*.5, the CTT2 channel).
    pub second: AsiAddress,
}

impl DoubleSlaveAddress {
    /// Both addresses; `None` if they are the same.
    pub fn new(first: AsiAddress, second: AsiAddress) -> Option<DoubleSlaveAddress> {
        (first != second).then_some(DoubleSlaveAddress { first, second })
    }
}

impl fmt::Display for DoubleSlaveAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.first, self.second)
    }
}

/// The 5 BusIO In bits (master → drive): bits 0–3 from the 1st slave, bit 4 from the 2nd.
/// Bit `n` is BusIO In bit `n + 1`, whose function is P480 `[-0n+1]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct BusIoIn(u8);

impl BusIoIn {
    /// Mask of the 5 bits.
    pub const MASK: u8 = 0x1F;

    /// The bits (bits above 4 are dropped).
    pub const fn new(bits: u8) -> BusIoIn {
        BusIoIn(bits & Self::MASK)
    }

    /// From the 4 data bits of the 1st slave and the 1 bit of the 2nd.
    pub const fn from_slaves(first: u8, second: u8) -> BusIoIn {
        BusIoIn((first & 0x0F) | ((second & 0x01) << 4))
    }

    /// The bits as the drive takes them (`SimulatedNord::set_busio_in`).
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// The 1st slave's 4 bits.
    pub const fn first(self) -> u8 {
        self.0 & 0x0F
    }

    /// The 2nd slave's bit.
    pub const fn second(self) -> u8 {
        self.0 >> 4
    }

    /// BusIO In bit `n` (1–5).
    pub const fn bit(self, n: u8) -> bool {
        n >= 1 && n <= 5 && self.0 & (1 << (n - 1)) != 0
    }

    /// With BusIO In bit `n` (1–5) set to `on` (other `n` change nothing).
    pub const fn with(self, n: u8, on: bool) -> BusIoIn {
        if n < 1 || n > 5 {
            return self;
        }
        let m = 1 << (n - 1);
        BusIoIn(if on { self.0 | m } else { self.0 & !m })
    }
}

/// The 6 BusIO Out bits (drive → master): bits 0–3 to the 1st slave, bits 4–5 to the 2nd. Bit
/// `n` is BusIO Out bit `n + 1`, whose function is P481 `[-0n+1]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct BusIoOut(u8);

impl BusIoOut {
    /// Mask of the 6 bits.
    pub const MASK: u8 = 0x3F;

    /// The bits (bits above 5 are dropped).
    pub const fn new(bits: u8) -> BusIoOut {
        BusIoOut(bits & Self::MASK)
    }

    /// The bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// The 1st slave's 4 bits.
    pub const fn first(self) -> u8 {
        self.0 & 0x0F
    }

    /// The 2nd slave's 2 bits.
    pub const fn second(self) -> u8 {
        self.0 >> 4
    }

    /// BusIO Out bit `n` (1–6).
    pub const fn bit(self, n: u8) -> bool {
        n >= 1 && n <= 6 && self.0 & (1 << (n - 1)) != 0
    }
}

/// The most slaves on one AS-i network (31 A + 31 B addresses).
pub const MAX_SLAVES: usize = 62;

/// The most double slaves on one AS-i network (section 3.3).
pub const MAX_DOUBLE_SLAVES: usize = 31;

/// What sits at an address of an [`AsiNetwork`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlaveAddress {
    /// A standard slave: the whole address 1–31 (both A and B).
    Standard(u8),
    /// A slave with extended addressing.
    Extended(AsiAddress),
}

impl SlaveAddress {
    fn clashes(self, other: SlaveAddress) -> bool {
        let n = |a: SlaveAddress| match a {
            SlaveAddress::Standard(n) => n,
            SlaveAddress::Extended(a) => a.number(),
        };
        match (self, other) {
            (SlaveAddress::Extended(a), SlaveAddress::Extended(b)) => a == b,
            _ => n(self) == n(other),
        }
    }
}

impl fmt::Display for SlaveAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SlaveAddress::Standard(n) => write!(f, "{n}"),
            SlaveAddress::Extended(a) => write!(f, "{a}"),
        }
    }
}

/// Why a slave cannot join an [`AsiNetwork`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum NetworkError {
    /// The address (or its standard / extended counterpart) is taken.
    #[error("AS-i address {0} is already in use")]
    AddressInUse(SlaveAddress),
    /// A standard address outside 1–31.
    #[error("AS-i address {0} is outside 1 to 31")]
    BadAddress(u8),
    /// 62 slaves are there already.
    #[error("the AS-i network is full (62 slaves)")]
    Full,
    /// 31 double slaves are there already (section 3.3).
    #[error("an AS-i network holds at most 31 double slaves")]
    TooManyDoubleSlaves,
    /// No double slave with this handle.
    #[error("no double slave {0} on this network")]
    NoSuchDoubleSlave(u8),
}

/// A double slave's handle in an [`AsiNetwork`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DoubleSlaveId(u8);

/// One member of the network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Member {
    address: SlaveAddress,
    /// The double slave it belongs to.
    double: Option<u8>,
}

/// The cyclic image of one double slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct DoubleImage {
    address: DoubleSlaveAddress,
    to_drive: BusIoIn,
    from_drive: BusIoOut,
}

/// An in-memory AS-i network: who is at which address, the cyclic BusIO image of each double
/// slave, and the CTT2 byte time its size gives. Fixed capacity, no allocation.
#[derive(Debug, Clone)]
pub struct AsiNetwork {
    members: [Option<Member>; MAX_SLAVES],
    doubles: [Option<DoubleImage>; MAX_DOUBLE_SLAVES],
}

impl Default for AsiNetwork {
    fn default() -> Self {
        Self::new()
    }
}

impl AsiNetwork {
    /// An empty network.
    pub const fn new() -> Self {
        Self {
            members: [None; MAX_SLAVES],
            doubles: [None; MAX_DOUBLE_SLAVES],
        }
    }

    /// The number of slaves (a double slave counts twice, as in section 4.4).
    pub fn slave_count(&self) -> u8 {
        self.members.iter().flatten().count() as u8
    }

    /// The number of double slaves.
    pub fn double_slave_count(&self) -> u8 {
        self.doubles.iter().flatten().count() as u8
    }

    /// The minimum CTT2 transfer time per byte: 16 × 154 µs × (2 + slaves) (section 4.4).
    pub fn byte_time(&self) -> Duration {
        Duration::from_micros(u64::from(ctt2_byte_time_us(self.slave_count())))
    }

    /// The CTT2 transfer time of `bytes` bytes.
    pub fn transfer_time(&self, bytes: usize) -> Duration {
        self.byte_time()
            .saturating_mul(bytes.min(u32::MAX as usize) as u32)
    }

    fn check_free(&self, address: SlaveAddress) -> Result<(), NetworkError> {
        if let SlaveAddress::Standard(n) = address
            && !(1..=31).contains(&n)
        {
            return Err(NetworkError::BadAddress(n));
        }
        if self
            .members
            .iter()
            .flatten()
            .any(|m| m.address.clashes(address))
        {
            return Err(NetworkError::AddressInUse(address));
        }
        Ok(())
    }

    fn free_slots(&self) -> usize {
        self.members.iter().filter(|m| m.is_none()).count()
    }

    fn insert(&mut self, m: Member) -> Result<(), NetworkError> {
        let slot = self
            .members
            .iter_mut()
            .find(|s| s.is_none())
            .ok_or(NetworkError::Full)?;
        *slot = Some(m);
        Ok(())
    }

    /// Add a single slave (standard or extended).
    pub fn add_slave(&mut self, address: SlaveAddress) -> Result<(), NetworkError> {
        self.check_free(address)?;
        self.insert(Member {
            address,
            double: None,
        })
    }

    /// Add a double slave at its two addresses.
    pub fn add_double_slave(
        &mut self,
        address: DoubleSlaveAddress,
    ) -> Result<DoubleSlaveId, NetworkError> {
        let first = SlaveAddress::Extended(address.first);
        let second = SlaveAddress::Extended(address.second);
        self.check_free(first)?;
        self.check_free(second)?;
        let Some(i) = self.doubles.iter().position(Option::is_none) else {
            return Err(NetworkError::TooManyDoubleSlaves);
        };
        if self.free_slots() < 2 {
            return Err(NetworkError::Full);
        }
        let id = i as u8;
        self.insert(Member {
            address: first,
            double: Some(id),
        })?;
        self.insert(Member {
            address: second,
            double: Some(id),
        })?;
        if let Some(slot) = self.doubles.get_mut(i) {
            *slot = Some(DoubleImage {
                address,
                to_drive: BusIoIn::default(),
                from_drive: BusIoOut::default(),
            });
        }
        Ok(DoubleSlaveId(id))
    }

    /// Remove the slave at `address` (a double slave goes as a whole).
    pub fn remove(&mut self, address: SlaveAddress) -> bool {
        let Some(m) = self
            .members
            .iter()
            .flatten()
            .find(|m| m.address == address)
            .copied()
        else {
            return false;
        };
        match m.double {
            Some(d) => {
                for s in &mut self.members {
                    if s.is_some_and(|x| x.double == Some(d)) {
                        *s = None;
                    }
                }
                if let Some(slot) = self.doubles.get_mut(usize::from(d)) {
                    *slot = None;
                }
            }
            None => {
                for s in &mut self.members {
                    if s.is_some_and(|x| x.address == address) {
                        *s = None;
                    }
                }
            }
        }
        true
    }

    /// The double slave whose 1st or 2nd slave is at `address`.
    pub fn double_slave_at(&self, address: AsiAddress) -> Option<DoubleSlaveId> {
        self.members
            .iter()
            .flatten()
            .find(|m| m.address == SlaveAddress::Extended(address))
            .and_then(|m| m.double)
            .map(DoubleSlaveId)
    }

    fn image(&mut self, id: DoubleSlaveId) -> Result<&mut DoubleImage, NetworkError> {
        self.doubles
            .get_mut(usize::from(id.0))
            .and_then(Option::as_mut)
            .ok_or(NetworkError::NoSuchDoubleSlave(id.0))
    }

    /// The addresses of a double slave.
    pub fn address_of(&self, id: DoubleSlaveId) -> Option<DoubleSlaveAddress> {
        self.doubles
            .get(usize::from(id.0))
            .copied()
            .flatten()
            .map(|d| d.address)
    }

    /// Set the bits the master sends to a double slave in the next cycle.
    pub fn set_outputs(&mut self, id: DoubleSlaveId, bits: BusIoIn) -> Result<(), NetworkError> {
        self.image(id)?.to_drive = bits;
        Ok(())
    }

    /// The bits the master last received from a double slave.
    pub fn inputs(&self, id: DoubleSlaveId) -> Result<BusIoOut, NetworkError> {
        self.doubles
            .get(usize::from(id.0))
            .copied()
            .flatten()
            .map(|d| d.from_drive)
            .ok_or(NetworkError::NoSuchDoubleSlave(id.0))
    }

    /// One AS-i cycle for a double slave: `drive` gets the master's bits and returns its own.
    pub fn exchange(
        &mut self,
        id: DoubleSlaveId,
        drive: impl FnOnce(BusIoIn) -> BusIoOut,
    ) -> Result<BusIoOut, NetworkError> {
        let image = self.image(id)?;
        image.from_drive = BusIoOut::new(drive(image.to_drive).bits());
        Ok(image.from_drive)
    }
}
