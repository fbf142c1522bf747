//! The native part of the `normalnet` Python package (PyO3, abi3): a thin
//! layer over the Rust crates. The Python wrapper (`normalnet/__init__.py`)
//! checks and converts arrays (float64 `N×3` vertices, int64 `M×3` faces,
//! C-contiguous) and turns keyword parameters into JSON, the one parameter
//! mechanism of `normalnet_denoise`; this module does the work with the GIL
//! released and turns Rust errors into Python exceptions with the Rust
//! message (`ValueError` for bad input and parameters, `OSError` for files,
//! `RuntimeError` otherwise).

mod attributes;

use normalnet_denoise::{DenoiseError, Denoiser, Kind, METHODS, Params};
use normalnet_mesh::{Mesh, MeshError, NoProgress, NoiseDirection, NoiseParams};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn mesh_error(e: MeshError) -> PyErr {
    match e {
        MeshError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn denoise_error(e: DenoiseError) -> PyErr {
    match e {
        DenoiseError::UnknownMethod { .. }
        | DenoiseError::Parameter { .. }
        | DenoiseError::NeedsGroundTruth { .. } => PyValueError::new_err(e.to_string()),
        DenoiseError::Mesh(m) => mesh_error(m),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// A mesh from the wrapper's arrays (already `N×3` float64 / `M×3` int64).
fn mesh_from(vertices: &PyReadonlyArray2<f64>, faces: &PyReadonlyArray2<i64>) -> PyResult<Mesh> {
    let v = vertices.as_array();
    let f = faces.as_array();
    if v.ncols() != 3 || f.ncols() != 3 {
        return Err(value_error(format!(
            "vertices must be N×3 and faces M×3, got {:?} and {:?}",
            v.shape(),
            f.shape()
        )));
    }
    let positions: Vec<[f64; 3]> = v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let n = positions.len() as i64;
    let mut tris = Vec::with_capacity(f.nrows());
    for (i, r) in f.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for k in 0..3 {
            if r[k] < 0 || r[k] >= n {
                return Err(value_error(format!(
                    "faces[{i}] = [{}, {}, {}]: index {} is outside 0..{n}",
                    r[0], r[1], r[2], r[k]
                )));
            }
            t[k] = r[k] as u32;
        }
        tris.push(t);
    }
    Mesh::new(positions, tris).map_err(mesh_error)
}

/// Vertices as returned to Python: float64 `N×3`.
type Vertices<'py> = Bound<'py, PyArray2<f64>>;
/// Faces as returned to Python: int64 `M×3`.
type Faces<'py> = Bound<'py, PyArray2<i64>>;

fn vertices_array<'py>(py: Python<'py>, mesh: &Mesh) -> Vertices<'py> {
    let flat: Vec<f64> = mesh.positions.iter().flatten().copied().collect();
    Array2::from_shape_vec((mesh.num_vertices(), 3), flat)
        .expect("N×3")
        .into_pyarray(py)
}

fn faces_array<'py>(py: Python<'py>, mesh: &Mesh) -> Faces<'py> {
    let flat: Vec<i64> = mesh.faces.iter().flatten().map(|&i| i as i64).collect();
    Array2::from_shape_vec((mesh.num_faces(), 3), flat)
        .expect("M×3")
        .into_pyarray(py)
}

fn parse_params(json: &str) -> PyResult<Params> {
    match serde_json::from_str::<serde_json::Value>(json).map_err(value_error)? {
        serde_json::Value::Object(m) => Ok(m),
        other => Err(value_error(format!(
            "parameters must be a mapping, got {other}"
        ))),
    }
}

/// Denoises a mesh; returns (vertices, resolved parameters as JSON, stage
/// times as JSON or None).
#[pyfunction]
#[pyo3(signature = (vertices, faces, method, params_json, gt_vertices=None, gt_faces=None))]
fn denoise<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    method: &str,
    params_json: &str,
    gt_vertices: Option<PyReadonlyArray2<'py, f64>>,
    gt_faces: Option<PyReadonlyArray2<'py, i64>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String, Option<String>)> {
    let mesh = mesh_from(&vertices, &faces)?;
    let gt = match (&gt_vertices, &gt_faces) {
        (Some(v), Some(f)) => Some(mesh_from(v, f)?),
        (None, None) => None,
        _ => return Err(value_error("gt needs both vertices and faces")),
    };
    let params = parse_params(params_json)?;
    let (out, parameters, stages) = py
        .detach(|| -> Result<_, DenoiseError> {
            let d = Denoiser::new(method, &params)?;
            let o = d.run(&mesh, gt.as_ref(), &NoProgress)?;
            let stages = o
                .stages
                .map(|s| serde_json::to_string(&s).unwrap_or_default());
            Ok((o.mesh, d.parameters().to_string(), stages))
        })
        .map_err(denoise_error)?;
    Ok((vertices_array(py, &out), parameters, stages))
}

/// The registered methods as JSON: name, aliases, summary, kind, defaults.
#[pyfunction]
fn methods() -> String {
    let list: Vec<serde_json::Value> = METHODS
        .iter()
        .map(|m| {
            serde_json::json!({
                "name": m.name,
                "aliases": m.aliases,
                "summary": m.summary,
                "kind": match m.kind {
                    Kind::Classical => "classical",
                    Kind::Learned => "learned",
                    Kind::Oracle => "oracle",
                },
                "defaults": (m.defaults)(),
            })
        })
        .collect();
    serde_json::Value::Array(list).to_string()
}

/// Synthetic noise (SPEC §2): σ = level × mean edge length.
#[pyfunction]
#[pyo3(signature = (vertices, faces, level, seed, impulsive, direction))]
fn noise<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    level: f64,
    seed: u64,
    impulsive: Option<f64>,
    direction: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mesh = mesh_from(&vertices, &faces)?;
    let direction = match direction {
        "normal" => NoiseDirection::Normal,
        "random" => NoiseDirection::Random,
        other => {
            return Err(value_error(format!(
                "direction {other:?}: expected \"normal\" or \"random\""
            )));
        }
    };
    let params = NoiseParams {
        level,
        impulsive_fraction: impulsive,
        direction,
        seed,
        ..NoiseParams::default()
    };
    let out = py
        .detach(|| normalnet_mesh::add_noise(&mesh, &params))
        .map_err(mesh_error)?;
    Ok(vertices_array(py, &out))
}

/// Error metrics of `result` against `gt` as JSON (the CLI's keys).
#[pyfunction]
fn metrics<'py>(
    py: Python<'py>,
    gt_vertices: PyReadonlyArray2<'py, f64>,
    gt_faces: PyReadonlyArray2<'py, i64>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
) -> PyResult<String> {
    let gt = mesh_from(&gt_vertices, &gt_faces)?;
    let result = mesh_from(&vertices, &faces)?;
    let m = py
        .detach(|| normalnet_mesh::metrics::compare(&gt, &result))
        .map_err(mesh_error)?;
    serde_json::to_string(&m).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Reads OBJ / OFF / PLY / STL; returns (vertices, faces).
#[pyfunction]
fn read_mesh<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Vertices<'py>, Faces<'py>)> {
    let mesh = py
        .detach(|| normalnet_mesh::read_mesh(&path))
        .map_err(mesh_error)?;
    Ok((vertices_array(py, &mesh), faces_array(py, &mesh)))
}

/// Reads a mesh file with what else it carries; returns (vertices, faces,
/// the attribute dict of [`attributes`], its `_file` entry included).
#[pyfunction]
fn read_mesh_attributes<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Vertices<'py>, Faces<'py>, Bound<'py, PyDict>)> {
    let file = py
        .detach(|| normalnet_mesh::read_mesh_file(&path))
        .map_err(mesh_error)?;
    let (vertices, faces) = (vertices_array(py, &file.mesh), faces_array(py, &file.mesh));
    let handle = attributes::FileAttributes {
        attributes: file.attributes,
        faces: file.mesh.faces,
        warnings: file.warnings,
    };
    let dict = attributes::attributes_dict(py, handle)?;
    Ok((vertices, faces, dict))
}

/// Writes `vertices` (new positions; `faces` those read) with the
/// attributes `file` holds and the edits of `edits` (the dict `file` came
/// in, arrays already float64 / int64), atomically; returns the warnings
/// (the reader's, then the writer's: what the output lacks, like
/// [`write_mesh_like`]). A changed shape or read-only entry is a ValueError
/// naming it.
#[pyfunction]
fn write_mesh_attributes<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    file: &Bound<'py, attributes::FileAttributes>,
    edits: &Bound<'py, PyDict>,
) -> PyResult<Vec<String>> {
    let mesh = mesh_from(&vertices, &faces)?;
    let file = file.get();
    if mesh.num_vertices() != file.attributes.num_vertices || mesh.faces.len() != file.faces.len() {
        return Err(value_error(format!(
            "the mesh has {} vertices and {} faces, its attributes were read from a file \
             with {} vertices and {} triangles",
            mesh.num_vertices(),
            mesh.num_faces(),
            file.attributes.num_vertices,
            file.faces.len()
        )));
    }
    if let Some(i) = (0..file.faces.len()).find(|&i| mesh.faces[i] != file.faces[i]) {
        return Err(value_error(format!(
            "faces[{i}] = {:?} differs from the file's triangle {:?}: the attributes \
             describe the file's connectivity (only positions can change)",
            mesh.faces[i], file.faces[i]
        )));
    }
    let attributes = attributes::apply_edits(file, edits)?;
    let written = py
        .detach(|| {
            normalnet_mesh::write_mesh_file(
                &path,
                &mesh,
                &attributes,
                &normalnet_mesh::FileWriteOptions::default(),
            )
        })
        .map_err(mesh_error)?;
    Ok(file.warnings.iter().cloned().chain(written).collect())
}

/// Writes a mesh (format from the extension), atomically.
#[pyfunction]
fn write_mesh<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
) -> PyResult<()> {
    let mesh = mesh_from(&vertices, &faces)?;
    py.detach(|| normalnet_mesh::write_mesh(&path, &mesh))
        .map_err(mesh_error)
}

/// Writes `vertices` (new positions of the mesh read from `input`, e.g.
/// denoised; `faces` as read) to `path` with everything else `input`
/// carries (issue 38: polygons, texture coordinates, materials, groups,
/// colours, extra PLY properties, STL attribute bytes; normals recomputed),
/// atomically; returns the warnings (what could not be kept). A mesh whose
/// counts differ from `input` is written without them (and a warning).
#[pyfunction]
fn write_mesh_like<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    input: std::path::PathBuf,
) -> PyResult<Vec<String>> {
    let mesh = mesh_from(&vertices, &faces)?;
    py.detach(|| -> Result<Vec<String>, MeshError> {
        let file = normalnet_mesh::read_mesh_file(&input)?;
        let mut warnings = file.warnings;
        match file.attributes.check_matches(&mesh) {
            Ok(()) => warnings.extend(normalnet_mesh::write_mesh_file(
                &path,
                &mesh,
                &file.attributes,
                &normalnet_mesh::FileWriteOptions::default(),
            )?),
            Err(e) => {
                normalnet_mesh::write_mesh(&path, &mesh)?;
                warnings.push(format!(
                    "{}: written without the attributes of {} ({e})",
                    path.display(),
                    input.display()
                ));
            }
        }
        Ok(warnings)
    })
    .map_err(mesh_error)
}

/// Renders to an `H×W×3` uint8 image; with gt, faces coloured by error.
#[pyfunction]
#[pyo3(signature = (vertices, faces, gt_vertices, gt_faces, width, height, azimuth, elevation, title, max_error))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    gt_vertices: Option<PyReadonlyArray2<'py, f64>>,
    gt_faces: Option<PyReadonlyArray2<'py, i64>>,
    width: u32,
    height: u32,
    azimuth: f64,
    elevation: f64,
    title: &str,
    max_error: Option<f64>,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let mesh = mesh_from(&vertices, &faces)?;
    let gt = match (&gt_vertices, &gt_faces) {
        (Some(v), Some(f)) => Some(mesh_from(v, f)?),
        _ => None,
    };
    let options = normalnet_render::RenderOptions {
        width,
        height,
        azimuth_deg: azimuth,
        elevation_deg: elevation,
        ..Default::default()
    };
    let image = py
        .detach(|| {
            normalnet_render::render_against_gt(&mesh, gt.as_ref(), &options, title, max_error)
        })
        .map_err(value_error)?;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let pixels =
        numpy::ndarray::Array3::from_shape_vec((h, w, 3), image.pixels().to_vec()).expect("H×W×3");
    Ok(pixels.into_pyarray(py))
}

/// The native module.
#[pymodule]
fn _normalnet(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(denoise, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(noise, m)?)?;
    m.add_function(wrap_pyfunction!(metrics, m)?)?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh_like, m)?)?;
    m.add_function(wrap_pyfunction!(read_mesh_attributes, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh_attributes, m)?)?;
    m.add_class::<attributes::FileAttributes>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
