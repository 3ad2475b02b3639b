//! The firmware's fuzz targets as plain functions, each with its oracle.
//!
//! | target | what it feeds | oracle beyond "no panic" |
//! |---|---|---|
//! | `mailbox` | raw mailbox writes, any header, any state, every profile's mailbox size | every reply well formed (Table 29/30, CoE), ESM |
//! | `sdo` | SDO transfers, complete access, SDO information on the profile's objects | replies well formed, aborts from Table 41, replies name requested indexes |
//! | `pdo` | arbitrary 1C12h/1C13h/16xxh/1Axxh contents → plan, unpack, pack | accepts exactly what the rules allow, `pack(unpack(x)) = x`, nothing else written |
//! | `esm` | AL control sequences, SM/FMMU/DC configurations, process data | no unrequested or skipped state, SMs valid in the states that need them |
//! | `params` | arbitrary flash images at power-on, then save all | only stored entries change, within range; what is saved loads back |
//! | `profile` | arbitrary TOML into od-gen | accepted profiles generate SII (good CRC), ESI, Rust |
//! | `frames` | whole Ethernet frames into the simulated ESC + firmware | length kept, write data untouched, working counters, ESM |
//!
//! libFuzzer runs them through `tests-host/fuzz` (`tests-host/fuzz/run`); `cargo test` replays
//! the committed corpora (`tests/replay.rs`), so a regression fails the test suite. A target
//! returns `Err` with what the oracle found; the libFuzzer wrapper turns that into a crash.

pub mod bench;
pub mod coe;
pub mod esm_watch;
pub mod input;
pub mod seeds;
pub mod spec;
pub mod targets;

pub use coe::Violation;

/// A fuzz target: its name (the corpus directory) and its function.
pub struct Target {
    /// Name.
    pub name: &'static str,
    /// Runs one input.
    pub run: fn(&[u8]) -> Result<(), Violation>,
}

/// Every target.
pub const TARGETS: &[Target] = &[
    Target {
        name: "mailbox",
        run: targets::mailbox::run,
    },
    Target {
        name: "sdo",
        run: targets::sdo::run,
    },
    Target {
        name: "pdo",
        run: targets::pdo::run,
    },
    Target {
        name: "esm",
        run: targets::esm::run,
    },
    Target {
        name: "params",
        run: targets::params::run,
    },
    Target {
        name: "profile",
        run: targets::profile::run,
    },
    Target {
        name: "frames",
        run: targets::frames::run,
    },
];
