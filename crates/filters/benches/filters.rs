//! Whole-denoiser timings of the classical methods with reference defaults
//! on `data/gd` (Fandisk0.3; Bunny0.2 for GNF/BNF/Sun07), to compare with the
//! reference C++ times of MEASURED.md. Run once per thread count:
//! `RAYON_NUM_THREADS=1 cargo bench -p normalnet-filters` and `=2`.
//! Skips (prints a message) when the shared data is absent.

// criterion_group! generates an undocumented function.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use normalnet_filters::{
    BiParams, BnfParams, ClassicalMethod, GnfParams, L0Params, Sun07Params, VtParams,
};
use normalnet_mesh::{Mesh, NoProgress, read_mesh};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/gd");

fn noisy(model: &str) -> Option<Mesh> {
    let path = Path::new(DATA).join(model).join("Noisy.obj");
    if !path.exists() {
        eprintln!("SKIP: {} not found", path.display());
        return None;
    }
    Some(read_mesh(path).expect("readable mesh"))
}

fn bench(c: &mut Criterion) {
    let threads = rayon::current_num_threads();
    let mut group = c.benchmark_group(format!("denoise_{threads}t"));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    type Run = (&'static str, Box<dyn Fn(&Mesh) -> Mesh>);
    fn run<P: ClassicalMethod>(name: &'static str, p: P) -> Run {
        (
            name,
            Box::new(move |m| normalnet_filters::denoise(&p, m, &NoProgress).unwrap()),
        )
    }
    let common = || {
        vec![
            run("gnf", GnfParams::default()),
            run("bnf", BnfParams::default()),
            run("sun07", Sun07Params::default()),
            run("bi", BiParams::default()),
            run("vt", VtParams::default()),
        ]
    };
    let mut fandisk = common();
    fandisk.push(run(
        "l0",
        L0Params {
            lambda_over_le2: 0.1,
            ..Default::default()
        },
    ));
    let plan: [(&str, Vec<Run>); 2] = [("Fandisk0.3", fandisk), ("Bunny0.2", common())];
    for (model, methods) in plan {
        let Some(mesh) = noisy(model) else { continue };
        for (name, method) in methods {
            group.bench_function(format!("{name}/{model}"), |b| {
                b.iter(|| black_box(method(black_box(&mesh))))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
