//! Classification of any valid frame into a [`Kind`] and a typed [`Message`].
//! Never fails: a frame it cannot type is [`Kind::Raw`].
//!
//! # Rule
//!
//! Requests (`FA AF`), first match wins:
//!
//! | kind | condition |
//! |---|---|
//! | `reboot` | ADDR 0xFE and payload exactly `DE AD` (any FLAGS) |
//! | `control` | ADDR 0x00 and a 15-byte payload (any FLAGS; with 0x05 it also asks for nav) |
//! | `ping` | FLAGS 0x01 and no payload (ADDR ignored) |
//! | `csr_read` | FLAGS ≥ 0x80 and no payload (the status read 0x8E @ 0x7A and the config read 0x80 @ 0xF7 included) |
//! | `raw` | anything else, e.g. the nav-only request V5 (FLAGS 0x05, no payload), single-register writes, custom commands, the engine-room write |
//!
//! Responses (`FD DF`):
//!
//! | kind | condition |
//! |---|---|
//! | `nav` | FLAGS 0x05, ADDR 0x00, 34-byte payload |
//! | `ping_reply` | FLAGS 0x01, ADDR 0x00, 9-byte payload |
//! | `status` | FLAGS ≥ 0x80, ADDR 0x7A, 15-byte payload |
//! | `config` | FLAGS ≥ 0x80, ADDR 0xF7, 293-byte payload |
//! | `csr_dump` | any other FLAGS ≥ 0x80 with at least the type byte |
//! | `raw` | anything else |

use core::fmt;

use crate::csr;
use crate::frame::{Direction, Frame, flags};
use crate::msg::{
    CONFIG_PAYLOAD_LEN, CONTROL_BLOCK_LEN, ConfigData, ControlBlock, CsrDump, CsrRead,
    NAV_PAYLOAD_LEN, NavReply, PING_REPLY_PAYLOAD_LEN, PingReply, STATUS_PAYLOAD_LEN, StatusBlock,
};

/// What a frame is (see the [module documentation](self) for the rule).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Kind {
    /// Control-block write (request).
    Control,
    /// Navigation reply (response).
    Nav,
    /// Ping / autodetect (request).
    Ping,
    /// Ping reply (response).
    PingReply,
    /// CSR read (request).
    CsrRead,
    /// CSR dump (response).
    CsrDump,
    /// Status block (response).
    Status,
    /// Configuration data (response).
    Config,
    /// Reboot (request).
    Reboot,
    /// Anything else.
    Raw,
}

impl Kind {
    /// Every kind.
    pub const ALL: [Self; 10] = [
        Self::Control,
        Self::Nav,
        Self::Ping,
        Self::PingReply,
        Self::CsrRead,
        Self::CsrDump,
        Self::Status,
        Self::Config,
        Self::Reboot,
        Self::Raw,
    ];

    /// snake_case name (`"control"`, `"ping_reply"`, ...).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Control => "control",
            Self::Nav => "nav",
            Self::Ping => "ping",
            Self::PingReply => "ping_reply",
            Self::CsrRead => "csr_read",
            Self::CsrDump => "csr_dump",
            Self::Status => "status",
            Self::Config => "config",
            Self::Reboot => "reboot",
            Self::Raw => "raw",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Classifies a frame by its shape (direction, FLAGS, ADDR, payload length).
#[must_use]
pub fn classify(frame: &Frame<'_>) -> Kind {
    let payload = frame.payload();
    let (f, addr, len) = (frame.flags(), frame.addr(), payload.len());
    match frame.direction() {
        Direction::Request => {
            if addr == csr::UTILITY && payload == csr::REBOOT_MAGIC {
                Kind::Reboot
            } else if addr == csr::CONTROL && len == CONTROL_BLOCK_LEN {
                Kind::Control
            } else if len == 0 && f == flags::PING {
                Kind::Ping
            } else if len == 0 && f >= flags::DUMP {
                Kind::CsrRead
            } else {
                Kind::Raw
            }
        }
        Direction::Response => {
            if f == flags::NAV && addr == 0 && len == NAV_PAYLOAD_LEN {
                Kind::Nav
            } else if f == flags::PING && addr == 0 && len == PING_REPLY_PAYLOAD_LEN {
                Kind::PingReply
            } else if f >= flags::DUMP && len >= 1 {
                if addr == csr::WATER_TEMP && len == STATUS_PAYLOAD_LEN {
                    Kind::Status
                } else if addr == csr::CONFIG_DATA && len == CONFIG_PAYLOAD_LEN {
                    Kind::Config
                } else {
                    Kind::CsrDump
                }
            } else {
                Kind::Raw
            }
        }
    }
}

/// A frame decoded into its typed message. Header fields (node, FLAGS, ...)
/// stay on the [`Frame`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(clippy::large_enum_variant)] // no heap: ConfigData (~300 B) stays inline
pub enum Message<'a> {
    /// Control-block write.
    Control(ControlBlock),
    /// Ping request.
    Ping,
    /// CSR read request.
    CsrRead(CsrRead),
    /// Reboot request.
    Reboot,
    /// Navigation reply.
    Nav(NavReply),
    /// Ping reply.
    PingReply(PingReply),
    /// Status block.
    Status(StatusBlock),
    /// Configuration data.
    Config(ConfigData),
    /// Other CSR dump.
    CsrDump(CsrDump<'a>),
    /// Not typed.
    Raw,
}

impl<'a> Message<'a> {
    /// Decodes a frame according to [`classify`]; never fails.
    /// `Message::decode(f).kind() == classify(f)` always holds.
    #[must_use]
    pub fn decode(frame: &Frame<'a>) -> Self {
        let typed = match classify(frame) {
            Kind::Control => ControlBlock::from_frame(frame).map(Self::Control),
            Kind::Ping => Ok(Self::Ping),
            Kind::CsrRead => CsrRead::from_frame(frame).map(Self::CsrRead),
            Kind::Reboot => Ok(Self::Reboot),
            Kind::Nav => NavReply::from_frame(frame).map(Self::Nav),
            Kind::PingReply => PingReply::from_frame(frame).map(Self::PingReply),
            Kind::Status => StatusBlock::from_frame(frame).map(Self::Status),
            Kind::Config => ConfigData::from_frame(frame).map(Self::Config),
            Kind::CsrDump => CsrDump::from_frame(frame).map(Self::CsrDump),
            Kind::Raw => Ok(Self::Raw),
        };
        typed.unwrap_or(Self::Raw)
    }

    /// The kind of this message.
    #[must_use]
    pub const fn kind(&self) -> Kind {
        match self {
            Self::Control(_) => Kind::Control,
            Self::Ping => Kind::Ping,
            Self::CsrRead(_) => Kind::CsrRead,
            Self::Reboot => Kind::Reboot,
            Self::Nav(_) => Kind::Nav,
            Self::PingReply(_) => Kind::PingReply,
            Self::Status(_) => Kind::Status,
            Self::Config(_) => Kind::Config,
            Self::CsrDump(_) => Kind::CsrDump,
            Self::Raw => Kind::Raw,
        }
    }
}
