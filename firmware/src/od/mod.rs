//! Object dictionary: the data model ([`model`]) and the run-time store ([`store`]).

pub mod model;
pub mod store;

pub use model::*;
pub use store::{Dictionary, StoreError};
