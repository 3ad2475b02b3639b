//! Object dictionary: the data model ([`model`]) and the run-time store ([`store`]).

pub mod model;

pub use model::*;
