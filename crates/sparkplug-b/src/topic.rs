//! Sparkplug topics (specification ch. 4): `spBv1.0/<group_id>/<TYPE>/<edge_node_id>` for the
//! edge node's messages, `…/<device_id>` added for a device's, and `spBv1.0/STATE/<host_id>` for
//! a host application's state.

use alloc::string::String;
use core::fmt;

/// The namespace element of every Sparkplug B topic.
pub const NAMESPACE: &str = "spBv1.0";

/// The message type (the topic's `message_type` element).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MessageType {
    /// `NBIRTH`: the edge node's birth certificate.
    NBirth,
    /// `NDEATH`: the edge node's death certificate (its MQTT will).
    NDeath,
    /// `DBIRTH`: a device's birth certificate.
    DBirth,
    /// `DDEATH`: a device's death certificate.
    DDeath,
    /// `NDATA`: the edge node's data.
    NData,
    /// `DDATA`: a device's data.
    DData,
    /// `NCMD`: a command to the edge node.
    NCmd,
    /// `DCMD`: a command to a device.
    DCmd,
    /// `STATE`: a host application's state (`spBv1.0/STATE/<host_id>`, JSON payload).
    State,
}

impl MessageType {
    /// Every message type, in the specification's order.
    pub const ALL: [MessageType; 9] = [
        MessageType::NBirth,
        MessageType::NDeath,
        MessageType::DBirth,
        MessageType::DDeath,
        MessageType::NData,
        MessageType::DData,
        MessageType::NCmd,
        MessageType::DCmd,
        MessageType::State,
    ];

    /// The topic element: `"NBIRTH"`, `"DDATA"`, `"STATE"`, ….
    pub fn as_str(self) -> &'static str {
        match self {
            MessageType::NBirth => "NBIRTH",
            MessageType::NDeath => "NDEATH",
            MessageType::DBirth => "DBIRTH",
            MessageType::DDeath => "DDEATH",
            MessageType::NData => "NDATA",
            MessageType::DData => "DDATA",
            MessageType::NCmd => "NCMD",
            MessageType::DCmd => "DCMD",
            MessageType::State => "STATE",
        }
    }

    /// The message type of a topic element (case-sensitive, as topics are).
    pub fn from_element(s: &str) -> Option<MessageType> {
        MessageType::ALL.into_iter().find(|t| t.as_str() == s)
    }

    /// Whether the topic has a device id: DBIRTH, DDEATH, DDATA and DCMD must, the others must
    /// not.
    pub fn has_device(self) -> bool {
        matches!(
            self,
            MessageType::DBirth | MessageType::DDeath | MessageType::DData | MessageType::DCmd
        )
    }
}

impl fmt::Display for MessageType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A Sparkplug B topic, borrowing its ids from the text it was parsed from (or the config).
///
/// `spBv1.0/<group>/<TYPE>/<node>[/<device>]`, and for [`MessageType::State`]
/// `spBv1.0/STATE/<host_id>`: then `node` is the host application's id, `group` is empty and
/// `device` is `None` (that is what [`parse`](Topic::parse) gives, and what
/// [`Display`](fmt::Display) writes from).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Topic<'a> {
    /// The group id.
    pub group: &'a str,
    /// The message type.
    pub kind: MessageType,
    /// The edge node id (for `State`, the host application's id).
    pub node: &'a str,
    /// The device id: present exactly for DBIRTH, DDEATH, DDATA and DCMD.
    pub device: Option<&'a str>,
}

impl<'a> Topic<'a> {
    /// Parse a topic name. Refuses another namespace, an unknown message type, a device id
    /// missing or where none belongs, missing or extra levels, and an id that
    /// [`check_id`] refuses (empty, or with `/`, `+`, `#` or U+0000).
    pub fn parse(s: &'a str) -> Result<Topic<'a>, TopicError> {
        let mut levels = s.split('/');
        if levels.next() != Some(NAMESPACE) {
            return Err(TopicError::Namespace);
        }
        let second = levels.next().ok_or(TopicError::Missing(Level::Group))?;
        let third = levels.next();
        let fourth = levels.next();
        if second == "STATE" && fourth.is_none() {
            let host = third.ok_or(TopicError::Missing(Level::Host))?;
            check_level(host, Level::Host)?;
            return Ok(Topic::state(host));
        }
        check_level(second, Level::Group)?;
        let third = third.ok_or(TopicError::Missing(Level::MessageType))?;
        let kind = MessageType::from_element(third).ok_or(TopicError::MessageType)?;
        if kind == MessageType::State {
            return Err(TopicError::MessageType);
        }
        let node = fourth.ok_or(TopicError::Missing(Level::Node))?;
        check_level(node, Level::Node)?;
        let device = levels.next();
        if levels.next().is_some() {
            return Err(TopicError::ExtraLevels);
        }
        match (kind.has_device(), device) {
            (true, None) => return Err(TopicError::Missing(Level::Device)),
            (false, Some(_)) => return Err(TopicError::DeviceNotAllowed(kind)),
            (true, Some(d)) => check_level(d, Level::Device)?,
            (false, None) => {}
        }
        Ok(Topic {
            group: second,
            kind,
            node,
            device,
        })
    }

    /// The topic of an edge node's own message (NBIRTH, NDEATH, NDATA, NCMD).
    pub fn node(group: &'a str, kind: MessageType, node: &'a str) -> Topic<'a> {
        Topic {
            group,
            kind,
            node,
            device: None,
        }
    }

    /// The topic of a device's message (DBIRTH, DDEATH, DDATA, DCMD).
    pub fn device(group: &'a str, kind: MessageType, node: &'a str, device: &'a str) -> Topic<'a> {
        Topic {
            group,
            kind,
            node,
            device: Some(device),
        }
    }

    /// The STATE topic of the host application `host_id`.
    pub fn state(host_id: &'a str) -> Topic<'a> {
        Topic {
            group: "",
            kind: MessageType::State,
            node: host_id,
            device: None,
        }
    }

    /// Check a topic built from parts: every id as [`check_id`] says, and a device id exactly
    /// where the message type has one. What passes formats to a topic that
    /// [`parse`](Topic::parse) gives back.
    pub fn check(&self) -> Result<(), TopicError> {
        if self.kind == MessageType::State {
            if !self.group.is_empty() {
                return Err(TopicError::GroupNotAllowed);
            }
            if self.device.is_some() {
                return Err(TopicError::DeviceNotAllowed(self.kind));
            }
            return check_level(self.node, Level::Host);
        }
        check_level(self.group, Level::Group)?;
        check_level(self.node, Level::Node)?;
        match (self.kind.has_device(), self.device) {
            (true, None) => Err(TopicError::Missing(Level::Device)),
            (false, Some(_)) => Err(TopicError::DeviceNotAllowed(self.kind)),
            (true, Some(d)) => check_level(d, Level::Device),
            (false, None) => Ok(()),
        }
    }
}

impl fmt::Display for Topic<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.kind == MessageType::State {
            return write!(f, "{NAMESPACE}/STATE/{}", self.node);
        }
        write!(f, "{NAMESPACE}/{}/{}/{}", self.group, self.kind, self.node)?;
        if let Some(device) = self.device {
            write!(f, "/{device}")?;
        }
        Ok(())
    }
}

/// `spBv1.0/STATE/<host_id>`: the topic a primary host application's state arrives on.
pub fn state_topic(host_id: &str) -> String {
    alloc::format!("{NAMESPACE}/STATE/{host_id}")
}

/// The filter of the commands to every device of an edge node: `spBv1.0/<group>/DCMD/<node>/+`
/// (the node subscribes to it, and to its NCMD topic, before it publishes its NBIRTH).
pub fn device_commands(group: &str, node: &str) -> String {
    alloc::format!("{NAMESPACE}/{group}/DCMD/{node}/+")
}

/// Check that `id` can be a group, edge node, device or host id, i.e. one topic level: not
/// empty, none of the characters MQTT reserves in topics (`/` separates levels, `+` and `#` are
/// wildcards) and no U+0000, which MQTT forbids in every string. (Rust strings are UTF-8
/// already, as the specification requires.)
pub fn check_id(id: &str) -> Result<(), TopicError> {
    check_level(id, Level::Id)
}

fn check_level(id: &str, level: Level) -> Result<(), TopicError> {
    if id.is_empty() {
        return Err(TopicError::Empty(level));
    }
    match id.chars().find(|c| matches!(c, '/' | '+' | '#' | '\0')) {
        Some(found) => Err(TopicError::Reserved { level, found }),
        None => Ok(()),
    }
}

/// Which level of a topic an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Level {
    /// The group id.
    Group,
    /// The message type.
    MessageType,
    /// The edge node id.
    Node,
    /// The device id.
    Device,
    /// The host application id of a STATE topic.
    Host,
    /// An id checked on its own ([`check_id`]).
    Id,
}

impl fmt::Display for Level {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Level::Group => "group id",
            Level::MessageType => "message type",
            Level::Node => "edge node id",
            Level::Device => "device id",
            Level::Host => "host application id",
            Level::Id => "id",
        })
    }
}

/// Why a topic or an id is not a Sparkplug B one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TopicError {
    /// The topic does not start with `spBv1.0/`.
    #[error("topic does not start with {NAMESPACE}/")]
    Namespace,
    /// A level the topic needs is missing.
    #[error("topic has no {0}")]
    Missing(Level),
    /// The message type element is none of NBIRTH, NDEATH, DBIRTH, DDEATH, NDATA, DDATA, NCMD,
    /// DCMD (STATE stands right after the namespace).
    #[error("unknown message type (NBIRTH, NDEATH, DBIRTH, DDEATH, NDATA, DDATA, NCMD or DCMD)")]
    MessageType,
    /// A device id after a message type that has none.
    #[error("{0} topics have no device id")]
    DeviceNotAllowed(MessageType),
    /// A group id on a STATE topic.
    #[error("a STATE topic has no group id")]
    GroupNotAllowed,
    /// More levels than the message type has.
    #[error("topic has more levels than its message type has")]
    ExtraLevels,
    /// An id is empty.
    #[error("{0} is empty")]
    Empty(Level),
    /// An id has a character no topic level may have.
    #[error("{level} has {found:?}, which no topic level may have (/, +, # and U+0000)")]
    Reserved {
        /// The id's level.
        level: Level,
        /// The first such character.
        found: char,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;

    #[test]
    fn the_specifications_topics_parse() {
        // Ch. 6: the examples' topics.
        let t = Topic::parse("spBv1.0/Sparkplug B Devices/NBIRTH/Raspberry Pi").unwrap();
        assert_eq!(
            t,
            Topic::node("Sparkplug B Devices", MessageType::NBirth, "Raspberry Pi")
        );
        let t = Topic::parse("spBv1.0/Sparkplug B Devices/DBIRTH/Raspberry Pi/Pibrella").unwrap();
        assert_eq!(t.device, Some("Pibrella"));
        assert_eq!(t.kind, MessageType::DBirth);
        assert_eq!(
            t.to_string(),
            "spBv1.0/Sparkplug B Devices/DBIRTH/Raspberry Pi/Pibrella"
        );
        let t = Topic::parse("spBv1.0/STATE/scada_host").unwrap();
        assert_eq!(t, Topic::state("scada_host"));
        assert_eq!(t.to_string(), state_topic("scada_host"));
        assert_eq!(state_topic("h1"), "spBv1.0/STATE/h1");
        assert_eq!(device_commands("g", "n"), "spBv1.0/g/DCMD/n/+");
    }

    #[test]
    fn every_message_type_formats_and_parses() {
        for kind in MessageType::ALL {
            assert_eq!(MessageType::from_element(kind.as_str()), Some(kind));
            let t = match kind {
                MessageType::State => Topic::state("host"),
                k if k.has_device() => Topic::device("g", k, "n", "d"),
                k => Topic::node("g", k, "n"),
            };
            assert_eq!(t.check(), Ok(()));
            assert_eq!(Topic::parse(&t.to_string()), Ok(t));
        }
        assert_eq!(MessageType::from_element("ndata"), None);
    }

    #[test]
    fn malformed_topics_are_refused() {
        use Level::*;
        let cases: &[(&str, TopicError)] = &[
            ("spAv1.0/g/NDATA/n", TopicError::Namespace),
            ("g/NDATA/n", TopicError::Namespace),
            ("spBv1.0", TopicError::Missing(Group)),
            ("spBv1.0/g", TopicError::Missing(MessageType)),
            ("spBv1.0/g/NDATA", TopicError::Missing(Node)),
            ("spBv1.0/g/DDATA/n", TopicError::Missing(Device)),
            ("spBv1.0/STATE", TopicError::Missing(Host)),
            ("spBv1.0/g/NOPE/n", TopicError::MessageType),
            ("spBv1.0/g/STATE/n", TopicError::MessageType),
            (
                "spBv1.0/g/NDATA/n/d",
                TopicError::DeviceNotAllowed(super::MessageType::NData),
            ),
            ("spBv1.0/g/DDATA/n/d/x", TopicError::ExtraLevels),
            ("spBv1.0//NDATA/n", TopicError::Empty(Group)),
            ("spBv1.0/g/NDATA/", TopicError::Empty(Node)),
            ("spBv1.0/g/DCMD/n/", TopicError::Empty(Device)),
            ("spBv1.0/STATE/", TopicError::Empty(Host)),
            (
                "spBv1.0/g+/NDATA/n",
                TopicError::Reserved {
                    level: Group,
                    found: '+',
                },
            ),
            (
                "spBv1.0/g/NDATA/#",
                TopicError::Reserved {
                    level: Node,
                    found: '#',
                },
            ),
        ];
        for (topic, err) in cases {
            assert_eq!(Topic::parse(topic), Err(*err), "{topic}");
        }
    }

    #[test]
    fn a_group_named_state_is_a_group_when_the_topic_has_four_levels() {
        let t = Topic::parse("spBv1.0/STATE/NDATA/n").unwrap();
        assert_eq!(t, Topic::node("STATE", MessageType::NData, "n"));
    }

    #[test]
    fn check_refuses_what_would_not_parse_back() {
        assert_eq!(
            Topic::node("g", MessageType::DData, "n").check(),
            Err(TopicError::Missing(Level::Device))
        );
        assert_eq!(
            Topic::device("g", MessageType::NCmd, "n", "d").check(),
            Err(TopicError::DeviceNotAllowed(MessageType::NCmd))
        );
        let state = Topic {
            group: "g",
            ..Topic::state("h")
        };
        assert_eq!(state.check(), Err(TopicError::GroupNotAllowed));
        assert_eq!(
            Topic::device("g", MessageType::DData, "n", "a/b").check(),
            Err(TopicError::Reserved {
                level: Level::Device,
                found: '/'
            })
        );
    }

    #[test]
    fn check_id_and_its_messages() {
        assert_eq!(check_id("Conveyor 1 (Halle Süd)"), Ok(()));
        assert_eq!(check_id(""), Err(TopicError::Empty(Level::Id)));
        let err = check_id("a\0b").unwrap_err();
        assert_eq!(
            err.to_string(),
            "id has '\\0', which no topic level may have (/, +, # and U+0000)"
        );
        assert_eq!(
            TopicError::Missing(Level::Device).to_string(),
            "topic has no device id"
        );
        assert_eq!(
            TopicError::DeviceNotAllowed(MessageType::NBirth).to_string(),
            "NBIRTH topics have no device id"
        );
    }
}
