//! Whole-denoiser timings of the classical methods with reference defaults
//! on `data/gd` (Fandisk0.3; Bunny0.2 for GNF/BNF/Sun07), to compare with the
//! reference C++ times of MEASURED.md. Run once per thread count:
//! `RAYON_NUM_THREADS=1 cargo bench -p normalnet-filters` and `=2`.
//! Skips (prints a message) when the shared data is absent.

// criterion_group! generates an undocumented function.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use normalnet_filters::{L0Params, Method};
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
    let l0 = Method::L0(L0Params {
        lambda_over_le2: 0.1,
        ..Default::default()
    });
    let plan: [(&str, Vec<Method>); 2] = [
        (
            "Fandisk0.3",
            vec![
                Method::from_name("gnf").unwrap(),
                Method::from_name("bnf").unwrap(),
                Method::from_name("sun07").unwrap(),
                Method::from_name("bi").unwrap(),
                Method::from_name("vt").unwrap(),
                l0,
            ],
        ),
        (
            "Bunny0.2",
            vec![
                Method::from_name("gnf").unwrap(),
                Method::from_name("bnf").unwrap(),
                Method::from_name("sun07").unwrap(),
                Method::from_name("bi").unwrap(),
                Method::from_name("vt").unwrap(),
            ],
        ),
    ];
    for (model, methods) in plan {
        let Some(mesh) = noisy(model) else { continue };
        for method in methods {
            group.bench_function(format!("{}/{model}", method.name()), |b| {
                b.iter(|| black_box(method.denoise(black_box(&mesh), &NoProgress).unwrap()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
