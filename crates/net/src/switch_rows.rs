//! The rows the learned switch is fitted on ([`crate::switch_fit`]): the
//! NormalNet pipeline run on a noisy/clean pair, with per face and
//! iteration the switch's features and each candidate's angle to the
//! ground truth. The vertices follow the normals a [`TracePath`] picks:
//! one candidate (the paper's form for a first table), the per-face best
//! (a ceiling), or a fitted switch (rows along its own path, for the next
//! fit).
//!
//! Row layout ([`crate::switch_fit::ROW_LEN`] f32 values): the
//! [`NUM_FEATURES`] features, then the [`NUM_CANDIDATES`] angles in
//! radians (CNR's features 0 and its angle NaN in runs traced without it,
//! [`TraceSettings::cnr`]); files of rows are [`ROWS_MAGIC`] and then those
//! values little endian, row after row ([`write_rows`], [`read_rows`]).
//! Files of the earlier layout (no header, 12 features and 4 angles per
//! row) are read as rows without CNR.

use std::io::{Read as _, Write as _};
use std::path::Path;

use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, NoProgress, Topology, compare};

use crate::NetError;
use crate::bundle::{Bundle, network_for_iteration};
use crate::pipeline::{filtered_normals, take_flat_means};
use crate::switch::{
    self, BASE_CANDIDATES, BASE_FEATURES, CNR, ITERATION_FEATURE, NUM_CANDIDATES, NUM_FEATURES,
    SwitchState, SwitchWeights,
};
use crate::switch_fit::ROW_LEN;

/// Which normals the vertices follow while rows are collected.
#[derive(Clone, Debug)]
pub enum TracePath {
    /// always candidate `j` (0 the network's output: the paper; 1 guided;
    /// 2 GNF; 3 stay; 4 CNR)
    Candidate(usize),
    /// per face the candidate closest to the ground truth
    Oracle,
    /// the blend of a fitted switch (its late table after its clamp)
    Learned(SwitchWeights),
}

/// Settings of one traced run.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceSettings {
    /// normal-filtering iterations
    pub iterations: usize,
    /// μ_g of the network output used (the bundle's nearest)
    pub mu_g: f64,
    /// vertex updates per iteration
    pub vertex_iterations: usize,
    /// from iteration 2 on, faces whose 2-ring is flat within this many
    /// degrees take the 2-ring mean as their network output, as the
    /// denoiser's flat skip does (0 = off)
    pub flat_skip_deg: f64,
    /// rows of earlier iterations are not kept (1 = all)
    pub min_iteration: usize,
    /// stop after an iteration whose network outputs turned less than this
    /// many degrees on average (0 = run every iteration)
    pub auto_stop_deg: f64,
    /// network inference batch
    pub inference_batch: usize,
    /// rows of faces folded in the mesh the iteration starts from
    /// ([`crate::switch::Candidates::folded`]) are not kept: a table fitted
    /// with [`SwitchWeights::network_on_folds`] never decides those faces,
    /// so their rows would only pull it toward the network elsewhere
    pub skip_folded: bool,
    /// compute the CNR candidate (CNR's normals of the input,
    /// [`switch::cnr_normals`]) so that the rows can fit a table with it;
    /// also whenever the path needs it
    pub cnr: bool,
}

impl Default for TraceSettings {
    fn default() -> Self {
        TraceSettings {
            iterations: 10,
            mu_g: 0.35,
            vertex_iterations: 20,
            flat_skip_deg: 0.0,
            min_iteration: 1,
            auto_stop_deg: 0.0,
            inference_batch: 256,
            skip_folded: false,
            cnr: false,
        }
    }
}

/// What one traced run gives.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// the kept rows, [`ROW_LEN`] values each
    pub rows: Vec<f32>,
    /// E_a (degrees) after each iteration run
    pub e_a_deg: Vec<f64>,
    /// how often each candidate had the largest weight (faces × iterations)
    pub chosen: [usize; NUM_CANDIDATES],
    /// rows left out as folded ([`TraceSettings::skip_folded`])
    pub skipped_folded: usize,
}

/// Runs the pipeline of `bundle` on `noisy` (vertices following `path`)
/// and collects the rows against the ground truth `gt`.
///
/// # Errors
/// A candidate index out of range, meshes that do not match, a network
/// output that is not finite.
pub fn trace(
    bundle: &Bundle,
    noisy: &Mesh,
    gt: &Mesh,
    path: &TracePath,
    settings: &TraceSettings,
) -> Result<Trace, NetError> {
    if let TracePath::Candidate(j) = path
        && *j >= NUM_CANDIDATES
    {
        return Err(NetError::InvalidParameter {
            name: "candidate",
            message: format!("{j} is not a candidate (0..{NUM_CANDIDATES})"),
        });
    }
    let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
    let gt_normals = face_normals(gt);
    if gt_normals.len() != noisy.num_faces() {
        return Err(NetError::InvalidParameter {
            name: "gt",
            message: format!(
                "{} faces, the noisy mesh {}",
                gt_normals.len(),
                noisy.num_faces()
            ),
        });
    }
    let n = noisy.num_faces();
    let mut positions = noisy.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let mut previous: Option<Vec<Vec3>> = None;
    // the learned path's table for this run, chosen in its first iteration
    let mut run_table: Option<std::borrow::Cow<'_, SwitchWeights>> = None;
    let cnr = settings.cnr
        || matches!(path, TracePath::Candidate(CNR))
        || matches!(path, TracePath::Learned(w) if w.needs_cnr());
    let mut state = SwitchState::new(noisy, &topology, settings.mu_g, cnr);
    let mut out = Trace::default();
    for k in 1..=settings.iterations {
        let current = noisy.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let (mut net, _) = filtered_normals(
            &current,
            &topology,
            &bundle.engines[i],
            bundle.manifest.networks[i].residual,
            bundle.voxel_params(),
            bundle.output_for_mu_g(settings.mu_g),
            settings.inference_batch,
            None,
            &NoProgress,
        )?;
        if settings.flat_skip_deg > 0.0 && k > 1 {
            take_flat_means(&current, &topology, settings.flat_skip_deg, &mut net);
        }
        let change = previous.as_ref().map_or(f64::INFINITY, |p| {
            p.iter()
                .zip(&net)
                .map(|(a, b)| vec3::angle(*a, *b).to_degrees())
                .sum::<f64>()
                / n as f64
        });
        previous = Some(net.clone());
        let c = state.candidates(&current, &topology, net);
        let features = switch::features(&topology, &c, k);
        let errors: Vec<[f64; NUM_CANDIDATES]> = (0..n)
            .map(|f| {
                std::array::from_fn(|j| {
                    c.normals[j]
                        .get(f)
                        .map_or(f64::NAN, |n| vec3::angle(*n, gt_normals[f]))
                })
            })
            .collect();
        if k >= settings.min_iteration {
            out.rows.reserve(n * ROW_LEN);
            for (f, (r, e)) in features.iter().zip(&errors).enumerate() {
                if settings.skip_folded && c.folded[f] {
                    out.skipped_folded += 1;
                    continue;
                }
                out.rows.extend(r.iter().chain(e.iter()).map(|x| *x as f32));
            }
        }
        let filtered = match path {
            TracePath::Candidate(j) => {
                out.chosen[*j] += n;
                c.normals[*j].clone()
            }
            TracePath::Oracle => (0..n)
                .map(|f| {
                    let best = (0..NUM_CANDIDATES)
                        .filter(|&j| !c.normals[j].is_empty())
                        .min_by(|&a, &b| errors[f][a].total_cmp(&errors[f][b]))
                        .unwrap_or(0);
                    out.chosen[best] += 1;
                    c.normals[best][f]
                })
                .collect(),
            TracePath::Learned(main) => {
                let w = &**run_table.get_or_insert_with(|| main.for_run_features(&features));
                for (f, x) in features.iter().enumerate() {
                    let best = if w.network_on_folds && c.folded[f] {
                        switch::NETWORK
                    } else {
                        let p = w.probabilities(x);
                        (0..NUM_CANDIDATES)
                            .max_by(|&a, &b| p[a].total_cmp(&p[b]))
                            .unwrap_or(0)
                    };
                    out.chosen[best] += 1;
                }
                switch::blend(w, &c, &features).0
            }
        };
        vertex_update_with(
            &mut positions,
            &noisy.faces,
            &topology,
            &filtered,
            &VertexUpdate {
                iterations: settings.vertex_iterations,
                fixed: None,
                fold_guard: Some(FOLD_GUARD_COS),
            },
            &mut buffers,
        );
        out.e_a_deg
            .push(compare(gt, &noisy.with_positions(positions.clone()))?.e_a_deg);
        if k > 1 && change < settings.auto_stop_deg {
            break;
        }
    }
    Ok(out)
}

/// The first bytes of a file of rows of [`ROW_LEN`] values.
pub const ROWS_MAGIC: &[u8; 16] = b"normalnet-rows19";

/// The row length of the files without [`ROWS_MAGIC`] (before the CNR
/// candidate): the base features, then the base candidates' angles.
const LEGACY_ROW_LEN: usize = BASE_FEATURES + BASE_CANDIDATES;

/// `rows` as little-endian bytes, after [`ROWS_MAGIC`] where `header`.
fn row_bytes(rows: &[f32], header: bool) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(rows.len() * 4 + ROWS_MAGIC.len());
    if header {
        bytes.extend_from_slice(ROWS_MAGIC);
    }
    for x in rows {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    bytes
}

/// Appends `rows` to `file` (f32 little endian; [`ROWS_MAGIC`] first where
/// the file is new or empty).
///
/// # Errors
/// I/O errors, naming the file; a file of the earlier layout.
pub fn append_rows(file: &Path, rows: &[f32]) -> Result<(), NetError> {
    let len = std::fs::metadata(file).map_or(0, |m| m.len());
    if len > 0 {
        // only the header says the layout: read it alone
        let mut head = Vec::with_capacity(ROWS_MAGIC.len());
        std::fs::File::open(file)
            .and_then(|f| std::io::Read::take(f, ROWS_MAGIC.len() as u64).read_to_end(&mut head))
            .map_err(|e| NetError::io(file, e))?;
        if head != ROWS_MAGIC {
            return Err(NetError::Record {
                path: file.to_path_buf(),
                message: "rows of the earlier layout (no CNR candidate); trace them again".into(),
            });
        }
    }
    let bytes = row_bytes(rows, len == 0);
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(file)
        .and_then(|mut f| f.write_all(&bytes))
        .map_err(|e| NetError::io(file, e))
}

/// Writes `rows` to `file` in one piece (replacing it; never a partial
/// file).
///
/// # Errors
/// I/O errors, naming the file.
pub fn write_rows(file: &Path, rows: &[f32]) -> Result<(), NetError> {
    crate::bundle::write_atomically(file, &row_bytes(rows, true))
}

/// The rows of `file` ([`ROW_LEN`] values each), the rows of iterations
/// before `min_iteration` left out. A file of the earlier layout gives rows
/// without CNR (its features 0, its angle NaN).
///
/// # Errors
/// I/O errors, a file that is not whole rows.
pub fn read_rows(file: &Path, min_iteration: usize) -> Result<Vec<f32>, NetError> {
    let bytes = std::fs::read(file).map_err(|e| NetError::io(file, e))?;
    let (body, row_len) = match bytes.strip_prefix(ROWS_MAGIC.as_slice()) {
        Some(body) => (body, ROW_LEN),
        None => (bytes.as_slice(), LEGACY_ROW_LEN),
    };
    if body.len() % (4 * row_len) != 0 {
        return Err(NetError::Record {
            path: file.to_path_buf(),
            message: format!(
                "{} bytes are not whole rows of {row_len} f32 values",
                body.len()
            ),
        });
    }
    let mut out = Vec::new();
    let mut row_values = [0f32; ROW_LEN];
    for row in body.chunks_exact(4 * row_len) {
        let values = &mut row_values[..row_len];
        for (v, b) in values.iter_mut().zip(row.chunks_exact(4)) {
            *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        if values[ITERATION_FEATURE] < min_iteration as f32 {
            continue;
        }
        if row_len == ROW_LEN {
            out.extend_from_slice(values);
        } else {
            let (features, angles) = values.split_at(BASE_FEATURES);
            out.extend_from_slice(features);
            out.extend(std::iter::repeat_n(0.0, NUM_FEATURES - BASE_FEATURES));
            out.extend_from_slice(angles);
            out.extend(std::iter::repeat_n(
                f32::NAN,
                NUM_CANDIDATES - BASE_CANDIDATES,
            ));
        }
    }
    Ok(out)
}

const _: () = assert!(ITERATION_FEATURE < BASE_FEATURES);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_filter_by_iteration() {
        let dir = std::env::temp_dir().join(format!("switch-rows-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("rows.bin");
        let row = |iteration: f32| -> Vec<f32> {
            (0..ROW_LEN)
                .map(|j| {
                    if j == ITERATION_FEATURE {
                        iteration
                    } else {
                        j as f32 * 0.5
                    }
                })
                .collect()
        };
        let rows: Vec<f32> = [1.0, 11.0, 3.0].iter().flat_map(|&i| row(i)).collect();
        write_rows(&file, &rows).unwrap();
        assert_eq!(read_rows(&file, 1).unwrap(), rows);
        assert_eq!(read_rows(&file, 4).unwrap(), row(11.0));
        append_rows(&file, &row(5.0)).unwrap();
        assert_eq!(read_rows(&file, 4).unwrap().len(), 2 * ROW_LEN);
        std::fs::write(&file, [0u8; 6]).unwrap();
        let err = read_rows(&file, 1).unwrap_err().to_string();
        assert!(err.contains("not whole rows"), "{err}");
        // a file of the earlier layout (12 features, 4 angles, no header)
        // reads as rows without CNR, and is not appended to
        let legacy: Vec<f32> = (0..LEGACY_ROW_LEN)
            .map(|j| {
                if j == ITERATION_FEATURE {
                    2.0
                } else {
                    j as f32
                }
            })
            .collect();
        let bytes: Vec<u8> = legacy.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(&file, bytes).unwrap();
        let read = read_rows(&file, 1).unwrap();
        assert_eq!(read.len(), ROW_LEN);
        assert_eq!(read[..BASE_FEATURES], legacy[..BASE_FEATURES]);
        assert_eq!(read[BASE_FEATURES..NUM_FEATURES], [0.0, 0.0]);
        assert_eq!(
            read[NUM_FEATURES..NUM_FEATURES + BASE_CANDIDATES],
            legacy[BASE_FEATURES..]
        );
        assert!(read[NUM_FEATURES + CNR].is_nan());
        let err = append_rows(&file, &row(1.0)).unwrap_err().to_string();
        assert!(err.contains("earlier layout"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
