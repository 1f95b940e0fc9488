#![no_main]
//! Any bytes given to the AMC parser give a motion or an error, never a panic;
//! a parsed motion survives writing, re-parsing and forward kinematics.

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

static SKELETON: OnceLock<cpg_mocap::Skeleton> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let sk = SKELETON.get_or_init(|| {
        cpg_mocap::parse_asf("tiny.asf", include_bytes!("../../test_data/tiny.asf")).expect("fixture parses")
    });
    if let Ok(m) = cpg_mocap::parse_amc("fuzz.amc", data, sk, 120.0) {
        let text = cpg_mocap::write_amc(sk, &m).expect("writes");
        let back = cpg_mocap::parse_amc("w.amc", text.as_bytes(), sk, 120.0).expect("re-parses");
        assert_eq!(back, m);
        let _ = sk.forward_kinematics(&m);
    }
});
