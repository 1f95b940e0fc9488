#![no_main]
//! Any bytes given to the ASF parser give a skeleton or an error, never a panic.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(sk) = cpg_mocap::parse_asf("fuzz.asf", data) {
        let _ = sk.topological_order();
    }
});
