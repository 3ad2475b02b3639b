//! The simulated board: a software ET1100 ([`esc`]) that processes real EtherCAT frames, with the
//! firmware core running against it ([`drive`]), in rings of any number of drives
//! ([`segment`]), reachable by real masters in process ([`inproc`], ethercrab) or over a network
//! interface ([`rawsock`], any master). [`storage`] is the board's parameter storage; [`axis_io`]
//! its axis hardware (the `hal` power, encoder and input drivers over the [`plant`]), which
//! [`servo`] wires to the firmware's control interrupt; [`workers`] are the helper threads a
//! segment spreads its drives over.

pub mod axis_io;
pub mod demo;
pub mod domains;
pub mod drive;
pub mod esc;
pub mod experiments;
pub mod inproc;
pub mod leds;
pub mod plant;
pub mod plot;
pub mod rawsock;
pub mod record;
pub mod segment;
pub mod servo;
pub mod storage;
pub mod tour;
pub mod workers;

pub use segment::{Segment, SegmentError, SimDevice};
