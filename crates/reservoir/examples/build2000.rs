//! Times building a 2000-neuron reservoir (spectral radius from the full eigenvalue decomposition).
#![allow(clippy::unwrap_used)]
fn main() {
    let cfg =
        cpg_reservoir::ReservoirConfig { n_neurons: 2000, ..cpg_reservoir::ReservoirConfig::wyffels_schrauwen_2009() }
            .check()
            .unwrap();
    let t = std::time::Instant::now();
    let r = cpg_reservoir::Reservoir::new(&cfg, 1).unwrap();
    println!("N=2000 built in {:?}, raw radius {}", t.elapsed(), r.raw_spectral_radius());
}
