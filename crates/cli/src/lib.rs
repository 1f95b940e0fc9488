//! The app layer of `cpg`, shared by the binary and by `cargo xtask`: the
//! training configuration, the data pipeline, free runs with control inputs,
//! and the stability measurements of `cpg evaluate`. Not a general-purpose
//! library: the reusable parts are the `cpg-*` crates below it.

#![allow(missing_docs)] // app glue; documented where it is used

pub mod config;
pub mod evaluate;
pub mod generate;
pub mod output;
pub mod pipeline;
