//! Output and input formats of the `cpg` command: `.npy` arrays for
//! `generate`, `fk` and `hoap2`; BVH written by `generate` (no --skeleton:
//! the model keeps its own) and read by `inspect`, `fk` and `view`.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

mod common;

use std::ffi::OsStr;
use std::path::Path;

use common::{cpg, ok, walk22};

/// A float64 C-order `.npy` file: its shape and values.
fn read_npy(path: &Path) -> (Vec<usize>, Vec<f64>) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY", "magic");
    let header_len = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(&b[10..10 + header_len]).unwrap();
    assert!(header.contains("'descr': '<f8'") && header.contains("'fortran_order': False"), "{header}");
    let shape_text = header.split("'shape': (").nth(1).unwrap().split(')').next().unwrap();
    let shape: Vec<usize> =
        shape_text.split(',').filter(|s| !s.trim().is_empty()).map(|s| s.trim().parse().unwrap()).collect();
    let data = &b[10 + header_len..];
    let values: Vec<f64> = data.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(values.len(), shape.iter().product::<usize>(), "the data fills the shape");
    (shape, values)
}

fn run(args: &[&OsStr]) -> String {
    ok(&cpg(args))
}

#[test]
fn npy_arrays_hold_what_the_csv_holds() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, npy) = (dir.path().join("g.csv"), dir.path().join("g.npy"));
    for out in [&csv, &npy] {
        run(&[
            "generate".as_ref(),
            "-m".as_ref(),
            walk22().as_os_str(),
            "--seconds".as_ref(),
            "2".as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
    }
    let (shape, values) = read_npy(&npy);
    assert_eq!(shape, [240, 22]);
    let text = std::fs::read_to_string(&csv).unwrap();
    for (k, line) in text.lines().skip(1).enumerate() {
        let row: Vec<f64> = line.split(',').skip(1).map(|v| v.parse().unwrap()).collect();
        for (c, v) in row.iter().enumerate() {
            assert!((v - values[k * 22 + c]).abs() < 1e-6, "row {k} column {c}");
        }
    }
    let h = dir.path().join("h.npy");
    let err = run(&[
        "hoap2".as_ref(),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "--rate-hz".as_ref(),
        "500".as_ref(),
        "-o".as_ref(),
        h.as_os_str(),
    ]);
    assert!(err.contains("frames × joints × (angle rad, velocity rad/s, acceleration rad/s²)"), "{err}");
    let (shape, values) = read_npy(&h);
    assert_eq!(shape, [500, 22, 3]);
    assert!(values.iter().all(|v| v.is_finite()));
}

#[test]
fn generated_bvh_reads_back_standing_and_drives_fk_and_view() {
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("walk.bvh");
    let err = run(&[
        "generate".as_ref(),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "3".as_ref(),
        "-o".as_ref(),
        bvh.as_os_str(),
    ]);
    assert!(err.contains("as bvh"), "{err}");
    let b = cpg_mocap::Bvh::from_file(&bvh, &cpg_mocap::BvhOptions::default()).unwrap();
    assert_eq!((b.motion.n_frames(), b.length_unit_mm), (360, 10.0));
    let p = b.skeleton.forward_kinematics(&b.motion).unwrap();
    for f in 0..p.n_frames() {
        let low = p.frame(f).iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
        assert!(low.abs() < 1e-3, "frame {f}: lowest point {low} mm");
    }
    let out = cpg(&["inspect".as_ref(), bvh.as_os_str()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success()
            && text.contains("BVH: 10 mm per length unit (inferred")
            && text.contains("360 frames at 120 Hz"),
        "{text}"
    );
    let pts = dir.path().join("p.npy");
    run(&["fk".as_ref(), bvh.as_os_str(), "-o".as_ref(), pts.as_os_str()]);
    let (shape, values) = read_npy(&pts);
    assert_eq!(shape[0], 360);
    assert_eq!(shape[2], 3);
    assert_eq!(shape[1], p.names.len());
    for (a, b) in values.iter().zip(p.points_mm.iter().flatten()) {
        assert!((a - b).abs() < 1e-9);
    }
    let html = dir.path().join("v.html");
    let err = run(&["view".as_ref(), "--motion".as_ref(), bvh.as_os_str(), "-o".as_ref(), html.as_os_str()]);
    assert!(err.contains("robot is left out") && err.contains("(360 frames, 3.0 s at 120 Hz: recording)"), "{err}");
    // A BVH with a skeleton, or an AMC without one, is refused with the reason.
    let o = cpg(&["fk".as_ref(), bvh.as_os_str(), "-s".as_ref(), bvh.as_os_str(), "-o".as_ref(), pts.as_os_str()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("carries its own skeleton"));
    let amc = common::cmu("35_01.amc");
    let o = cpg(&["fk".as_ref(), amc.as_os_str(), "-o".as_ref(), pts.as_os_str()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("give its ASF skeleton"));
}
