//! Balanced sampler and threaded loader.

mod common;
use common::{grid_cube, noisy_copy};
use normalnet_samples::{BalancedSampler, Loader, LoaderConfig, MU_GS, SampleSource};
use normalnet_voxel::VoxelParams;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::HashSet;
use std::sync::Arc;

fn sources() -> Vec<SampleSource> {
    [(6, 1), (9, 2)]
        .into_iter()
        .map(|(n, seed)| {
            let clean = grid_cube(n);
            SampleSource::new(
                noisy_copy(&clean, 0.1, seed),
                &clean,
                VoxelParams::tiny(),
                &MU_GS,
            )
            .unwrap()
        })
        .collect()
}

#[test]
fn balanced_draws_have_equal_category_counts() {
    let srcs = sources();
    let sampler = BalancedSampler::new(&srcs);
    let sizes = sampler.category_sizes();
    assert_eq!(sampler.non_empty_categories(), vec![0, 3], "{sizes:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let items = sampler.draw_balanced(500, &mut rng);
    assert_eq!(items.len(), 1000);
    for c in [0u8, 3] {
        assert_eq!(items.iter().filter(|i| i.category == c).count(), 500);
    }
    // Without replacement while the pool lasts: the smaller pool (category 0
    // has fewer faces than 500? then all of it appears) has no early repeats.
    let small = sizes[0].min(sizes[3]).min(500);
    let c = if sizes[0] <= sizes[3] { 0 } else { 3 };
    let distinct: HashSet<_> = items
        .iter()
        .filter(|i| i.category == c)
        .map(|i| (i.source, i.face))
        .collect();
    assert!(distinct.len() >= small, "{} < {small}", distinct.len());
    // Both sources appear, and categories match the sources' own lists.
    assert!(items.iter().any(|i| i.source == 0) && items.iter().any(|i| i.source == 1));
    for i in &items {
        assert_eq!(
            srcs[i.source as usize].categories()[i.face as usize],
            i.category
        );
    }
    let counted = sampler.draw_count(7, &mut rng);
    assert_eq!(counted.len(), 7);
    let again = sampler.draw_balanced(500, &mut ChaCha8Rng::seed_from_u64(1));
    assert_eq!(again, items, "same seed, same draw");
}

#[test]
fn loader_is_deterministic_and_independent_of_worker_count() {
    let srcs = Arc::new(sources());
    let sampler = BalancedSampler::new(srcs.iter());
    let items = sampler.draw_balanced(30, &mut ChaCha8Rng::seed_from_u64(3));
    let run = |workers| {
        let config = LoaderConfig {
            batch_size: 8,
            workers,
            seed: 42,
            ..LoaderConfig::default()
        };
        Loader::new(Arc::clone(&srcs), items.clone(), config)
            .unwrap()
            .collect::<Vec<_>>()
    };
    let one = run(1);
    let three = run(3);
    assert_eq!(one.len(), 60usize.div_ceil(8));
    assert_eq!(one.last().unwrap().len(), 60 % 8);
    let grid_len = VoxelParams::tiny().grid_len();
    for (a, b) in one.iter().zip(&three) {
        assert_eq!(a.index, b.index);
        assert_eq!(a.items, b.items);
        assert_eq!(a.yaws, b.yaws);
        assert_eq!(a.grids, b.grids);
        assert_eq!(a.targets, b.targets);
        assert_eq!(a.grids.len(), a.len() * grid_len);
    }
    // The loader's sample equals a direct one with the same yaw.
    let b = &one[1];
    let it = b.items[2];
    let mut grid = vec![0.0f32; grid_len];
    let t = srcs[it.source as usize].sample(it.face as usize, b.yaws[2], &mut grid);
    assert_eq!(&b.targets[2 * 18..3 * 18], &t);
    assert_eq!(&b.grids[2 * grid_len..3 * grid_len], &grid[..]);
    // Yaws are spread over [0, 2π).
    let yaws: Vec<f64> = one.iter().flat_map(|b| b.yaws.clone()).collect();
    assert!(
        yaws.iter()
            .all(|y| (0.0..std::f64::consts::TAU).contains(y))
    );
    assert!(yaws.iter().any(|y| *y > 3.0) && yaws.iter().any(|y| *y < 3.0));
}

#[test]
fn a_loader_started_after_some_batches_gives_the_rest_of_the_run() {
    // what a resumed training run relies on: the items after the first s
    // batches with first_stream = s are the whole run's batches s, s+1, ...
    let srcs = Arc::new(sources());
    let sampler = BalancedSampler::new(srcs.iter());
    let items = sampler.draw_balanced(30, &mut ChaCha8Rng::seed_from_u64(5));
    let config = LoaderConfig {
        batch_size: 8,
        seed: 7,
        keep_last: false,
        ..LoaderConfig::default()
    };
    let whole: Vec<_> = Loader::new(Arc::clone(&srcs), items.clone(), config)
        .unwrap()
        .collect();
    let skip = 3;
    let rest: Vec<_> = Loader::new(
        Arc::clone(&srcs),
        items[skip * 8..].to_vec(),
        LoaderConfig {
            first_stream: skip as u64,
            ..config
        },
    )
    .unwrap()
    .collect();
    assert_eq!(rest.len(), whole.len() - skip);
    for (a, b) in whole[skip..].iter().zip(&rest) {
        assert_eq!(a.items, b.items);
        assert_eq!(a.yaws, b.yaws);
        assert_eq!(a.grids, b.grids);
    }
    // without the offset the yaws differ (the old resume did that)
    let unshifted: Vec<_> = Loader::new(Arc::clone(&srcs), items[skip * 8..].to_vec(), config)
        .unwrap()
        .collect();
    assert_ne!(unshifted[0].yaws, rest[0].yaws);
}

#[test]
fn loader_drops_cleanly_and_checks_input() {
    let srcs = Arc::new(sources());
    let sampler = BalancedSampler::new(srcs.iter());
    let items = sampler.draw_balanced(100, &mut ChaCha8Rng::seed_from_u64(4));
    let mut loader = Loader::new(
        Arc::clone(&srcs),
        items.clone(),
        LoaderConfig {
            batch_size: 4,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(loader.next().is_some());
    drop(loader); // workers blocked on a full channel must exit
    let cfg = LoaderConfig {
        batch_size: 0,
        ..Default::default()
    };
    assert!(Loader::new(Arc::clone(&srcs), items.clone(), cfg).is_err());
    let mut bad = items;
    bad[0].face = 1_000_000;
    assert!(
        Loader::new(srcs, bad, LoaderConfig::default())
            .unwrap_err()
            .to_string()
            .contains("items")
    );
}
