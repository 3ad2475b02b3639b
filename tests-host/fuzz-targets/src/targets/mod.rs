//! The fuzz targets, one module each.

pub mod esm;
pub mod frames;
pub mod mailbox;
pub mod params;
pub mod pdo;
pub mod profile;
pub mod sdo;
