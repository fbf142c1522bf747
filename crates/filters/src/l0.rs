//! Mesh denoising via L0 minimization: He, Schaefer (2013), ACM TOG 32(4)
//! (SIGGRAPH), doi:10.1145/2461912.2461965, §4–5; SPEC §9. Edge-based L0 with
//! the area-based regulariser, solved by alternating optimisation.
//!
//! Energy: `min_{p,δ} |p − p*|² + α|R p|² + β|D p − δ|² + λ|δ|₀` over vertex
//! positions p (p* the input) and one auxiliary 3-vector δ_e per interior edge.
//! For the edge `e = (p1, p3)` with faces `(p1, p2, p3)` and `(p1, p3, p4)`:
//! - `D(e)` (paper Eq. 6, the cotangent-like edge operator):
//!   `D(e) = (S_134·h_2 + S_123·h_4) / (S_123 + S_134)`, where `h_k` is the
//!   component of `p_k − p1` orthogonal to the edge and `S` the triangle
//!   areas; it vanishes exactly when the two triangles are coplanar. As a
//!   linear combination of p1..p4 its coefficients are
//!   `[−c2−c3−c4, c2, c3, c4]` with `c2 = S_134/S`, `c4 = S_123/S`,
//!   `c3 = −(S_134·s_2 + S_123·s_4)/S`, `s_k = (p_k − p1)·(p3 − p1)/|p3 − p1|²`.
//!   The coefficients are evaluated at the current positions every
//!   iteration (the sparsity pattern, and so the symbolic factorisation, is
//!   fixed).
//! - `R(e) = p1 − p2 + p3 − p4` (the area-based regulariser, zero for a
//!   parallelogram), which keeps triangles from degenerating.
//!
//! Alternation (paper Algorithm 1): δ-step — per edge hard threshold,
//! `δ_e = D(e)p` if `|D(e)p|² ≥ λ/β`, else 0; p-step — the sparse SPD system
//! `(I + αRᵀR + βDᵀD) p = p* + βDᵀδ` (three right-hand sides x, y, z), solved
//! by faer's sparse Cholesky (AMD ordering) with the symbolic factorisation
//! computed once and the numeric one sequential.
//! Then `β ← κβ`, `α ← μ_α·α`, until `β > β_max`.
//!
//! Constants (the paper's): `β_0 = 0.001`, `β_max = 1000`, `κ = 1.414`,
//! `α_0 = 0.1·γ̄` (γ̄ the mean dihedral angle of the input in radians),
//! `μ_α = 0.5`; λ is given in units of `l_e²` (mean edge length of the input),
//! default `0.05·l_e²` (MEASURED.md's column; no λ suits every model).
//! Boundary and non-manifold edges get no D/R term.

use crate::error::{FilterError, check_range};
use crate::stats::mean_edge_length;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{SymmetricOrdering, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Par, Side};
use normalnet_mesh::geometry::{face_normals, triangle_area};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Progress, Topology};
use rayon::prelude::*;

/// Parameters of L0 denoising; `Default` is the paper's constants with
/// `λ = 0.05·l_e²`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct L0Params {
    /// λ / l_e²: weight of the L0 term in units of the squared mean edge
    /// length; default 0.05.
    pub lambda_over_le2: f64,
    /// β_0: initial weight of the coupling term; default 0.001.
    pub beta0: f64,
    /// β_max: the iteration stops once β exceeds it; default 1000, at most
    /// [`BETA_MAX_LIMIT`].
    pub beta_max: f64,
    /// κ: growth factor of β per iteration; default 1.414.
    pub kappa: f64,
    /// α_0 / γ̄: initial regulariser weight in units of the input's mean
    /// dihedral angle γ̄ (radians); default 0.1.
    pub alpha0_over_gamma: f64,
    /// μ_α: decay factor of α per iteration; default 0.5.
    pub alpha_decay: f64,
}

impl Default for L0Params {
    fn default() -> Self {
        L0Params {
            lambda_over_le2: 0.05,
            beta0: 0.001,
            beta_max: 1000.0,
            kappa: 1.414,
            alpha0_over_gamma: 0.1,
            alpha_decay: 0.5,
        }
    }
}

/// The largest β_max [`L0Params::validate`] accepts. The p-step solves
/// `(I + αRᵀR + βDᵀD) p = …` with dimensionless `D`: as β grows the identity
/// drowns in the singular `βDᵀD` and the Cholesky factorisation loses
/// positive pivots (past 1e16 on a 300-face sphere: 1e20 fails); 1e8 keeps
/// eight digits of margin and is 1e5 times the paper's 1000.
pub const BETA_MAX_LIMIT: f64 = 1e8;

impl L0Params {
    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        check_range(
            "lambda_over_le2",
            self.lambda_over_le2,
            Some(0.0),
            None,
            false,
        )?;
        check_range("beta0", self.beta0, Some(0.0), None, true)?;
        check_range(
            "beta_max",
            self.beta_max,
            Some(self.beta0),
            Some(BETA_MAX_LIMIT),
            false,
        )?;
        check_range("kappa", self.kappa, Some(1.0), None, true)?;
        check_range(
            "alpha0_over_gamma",
            self.alpha0_over_gamma,
            Some(0.0),
            None,
            false,
        )?;
        check_range("alpha_decay", self.alpha_decay, Some(0.0), Some(1.0), false)?;
        // β grows geometrically: bound the iteration count.
        if self.iterations() > 10_000 {
            return Err(FilterError::InvalidParameter {
                name: "kappa",
                message: format!(
                    "{} iterations from beta0 to beta_max; use a larger kappa",
                    self.iterations()
                ),
            });
        }
        Ok(())
    }

    /// Number of outer iterations: β_0·κ^k for k = 0.. while ≤ β_max.
    pub fn iterations(&self) -> usize {
        if !(self.kappa > 1.0 && self.beta0 > 0.0) {
            return 0;
        }
        let mut beta = self.beta0;
        let mut k = 0;
        while beta <= self.beta_max && k <= 10_001 {
            beta *= self.kappa;
            k += 1;
        }
        k
    }
}

/// One interior edge: vertices `[p1, p2, p3, p4]` (edge p1–p3, opposite p2, p4).
type Stencil = [u32; 4];

/// The 4-vertex stencils of all interior manifold edges with two distinct
/// opposite vertices.
fn stencils(mesh: &Mesh, topology: &Topology) -> Vec<Stencil> {
    let opposite = |f: u32, a: u32, b: u32| {
        mesh.faces[f as usize]
            .iter()
            .copied()
            .find(|&v| v != a && v != b)
    };
    (0..topology.edges.len())
        .filter(|&e| topology.edge_face_count[e] == 2)
        .filter_map(|e| {
            let [a, b] = topology.edges[e];
            let [f, g] = topology.edge_faces[e];
            let p2 = opposite(f, a, b)?;
            let p4 = opposite(g, a, b)?;
            (a != b && p2 != p4).then_some([a, p2, b, p4])
        })
        .collect()
}

/// The D(e) coefficients of a stencil at `positions` (zero when degenerate).
#[inline]
fn d_coefficients(s: &Stencil, positions: &[Vec3]) -> [f64; 4] {
    let [p1, p2, p3, p4] = s.map(|v| positions[v as usize]);
    let e = vec3::sub(p3, p1);
    let e2 = vec3::norm2(e);
    let s123 = triangle_area(p1, p2, p3);
    let s134 = triangle_area(p1, p3, p4);
    let total = s123 + s134;
    if !(e2 > 0.0 && total > 0.0) {
        return [0.0; 4];
    }
    let s2 = vec3::dot(vec3::sub(p2, p1), e) / e2;
    let s4 = vec3::dot(vec3::sub(p4, p1), e) / e2;
    let c2 = s134 / total;
    let c4 = s123 / total;
    let c3 = -(s134 * s2 + s123 * s4) / total;
    [-c2 - c3 - c4, c2, c3, c4]
}

/// `R(e)` coefficients.
const R_COEFFICIENTS: [f64; 4] = [1.0, -1.0, 1.0, -1.0];

/// Mean dihedral angle γ̄ (radians) over interior edges: the angle between
/// the two face normals; 0 when there is none.
pub fn mean_dihedral_angle(mesh: &Mesh, topology: &Topology) -> f64 {
    let normals = face_normals(mesh);
    let (sum, count) = (0..topology.edges.len())
        .filter(|&e| topology.edge_face_count[e] == 2)
        .map(|e| {
            let [f, g] = topology.edge_faces[e];
            vec3::angle(normals[f as usize], normals[g as usize])
        })
        .fold((0.0, 0usize), |(s, c), a| (s + a, c + 1));
    if count == 0 { 0.0 } else { sum / count as f64 }
}

/// Upper-triangular CSC pattern of `I + αRᵀR + βDᵀD` with, per stencil, the
/// value slot of each of its 10 upper entries.
struct Pattern {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    diagonal: Vec<usize>,
    slots: Vec<[usize; 10]>,
}

/// Pairs (a, b) with a ≤ b of a stencil's 4 local indices, in slot order.
const PAIRS: [(usize, usize); 10] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (0, 3),
    (1, 1),
    (1, 2),
    (1, 3),
    (2, 2),
    (2, 3),
    (3, 3),
];

impl Pattern {
    fn new(n: usize, stencils: &[Stencil]) -> Pattern {
        let mut entries: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        for s in stencils {
            for &(a, b) in &PAIRS {
                let (u, v) = (s[a] as usize, s[b] as usize);
                // Upper triangle: (row, col) with row ≤ col; sort by column.
                entries.push((u.max(v), u.min(v)));
            }
        }
        entries.par_sort_unstable();
        entries.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(entries.len());
        for &(col, row) in &entries {
            col_ptr[col + 1] += 1;
            row_idx.push(row);
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let slot = |row: usize, col: usize| -> usize {
            let r = &row_idx[col_ptr[col]..col_ptr[col + 1]];
            col_ptr[col] + r.binary_search(&row).expect("entry in pattern")
        };
        let diagonal = (0..n).map(|i| slot(i, i)).collect();
        let slots = stencils
            .par_iter()
            .map(|s| {
                PAIRS.map(|(a, b)| {
                    let (u, v) = (s[a] as usize, s[b] as usize);
                    slot(u.min(v), u.max(v))
                })
            })
            .collect();
        Pattern {
            col_ptr,
            row_idx,
            diagonal,
            slots,
        }
    }
}

/// Denoises `mesh` by L0 minimisation.
pub fn l0(mesh: &Mesh, params: &L0Params, progress: &dyn Progress) -> Result<Mesh, FilterError> {
    params.validate()?;
    let n = mesh.num_vertices();
    let topology = Topology::new(n, &mesh.faces);
    let stencils = stencils(mesh, &topology);
    let l_e = mean_edge_length(mesh, &topology);
    let lambda = params.lambda_over_le2 * l_e * l_e;
    let mut alpha = params.alpha0_over_gamma * mean_dihedral_angle(mesh, &topology);
    let mut beta = params.beta0;
    let iterations = params.iterations();

    let pattern = Pattern::new(n, &stencils);
    let symbolic_ref =
        SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
    let solver_error =
        |iteration: usize, message: String| FilterError::Solver { iteration, message };
    let symbolic = factorize_symbolic_cholesky(
        symbolic_ref,
        Side::Upper,
        SymmetricOrdering::Amd,
        Default::default(),
    )
    .map_err(|e| solver_error(0, format!("{e:?}")))?;
    // faer runs sequentially here: on these sizes its parallel
    // factorisation is slower (Fandisk0.3, 2 threads: 0.82 s vs 0.26 s).
    let par = Par::Seq;
    let mut l_values = vec![0.0f64; symbolic.len_val()];
    let mut factor_memory =
        MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
    let mut solve_memory = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(3, par));

    let p_star = &mesh.positions;
    let mut positions = p_star.clone();
    let mut values = vec![0.0f64; pattern.row_idx.len()];
    let mut coefficients: Vec<[f64; 4]> = vec![[0.0; 4]; stencils.len()];
    let mut delta: Vec<Vec3> = vec![[0.0; 3]; stencils.len()];
    let mut rhs = Mat::<f64>::zeros(n, 3);

    progress.start("L0", iterations as u64);
    for iteration in 0..iterations {
        // D(e) at the current positions, then the δ-step (hard threshold).
        let threshold = lambda / beta;
        coefficients
            .par_iter_mut()
            .zip(delta.par_iter_mut())
            .zip(stencils.par_iter())
            .with_min_len(1024)
            .for_each(|((c, d), s)| {
                *c = d_coefficients(s, &positions);
                let mut dp = [0.0; 3];
                for k in 0..4 {
                    dp = vec3::add(dp, vec3::scale(positions[s[k] as usize], c[k]));
                }
                *d = if vec3::norm2(dp) >= threshold {
                    dp
                } else {
                    [0.0; 3]
                };
            });

        // p-step: assemble (I + αRᵀR + βDᵀD) and p* + βDᵀδ.
        values.fill(0.0);
        for &slot in &pattern.diagonal {
            values[slot] = 1.0;
        }
        for (i, p) in p_star.iter().enumerate() {
            for k in 0..3 {
                rhs[(i, k)] = p[k];
            }
        }
        for ((s, c), (slots, d)) in stencils
            .iter()
            .zip(&coefficients)
            .zip(pattern.slots.iter().zip(&delta))
        {
            for (q, &(a, b)) in PAIRS.iter().enumerate() {
                let mut v = beta * c[a] * c[b] + alpha * R_COEFFICIENTS[a] * R_COEFFICIENTS[b];
                // Off-diagonal pairs of a stencil appear once in PAIRS but
                // twice in the symmetric product; a diagonal pair whose two
                // stencil vertices coincide cannot occur (distinct vertices).
                if a != b && s[a] == s[b] {
                    v *= 2.0;
                }
                values[slots[q]] += v;
            }
            if *d != [0.0; 3] {
                for a in 0..4 {
                    let row = s[a] as usize;
                    for k in 0..3 {
                        rhs[(row, k)] += beta * c[a] * d[k];
                    }
                }
            }
        }
        let matrix = SparseColMatRef::new(symbolic_ref, &values);
        let llt = symbolic
            .factorize_numeric_llt::<f64>(
                &mut l_values,
                matrix,
                Side::Upper,
                Default::default(),
                par,
                MemStack::new(&mut factor_memory),
                Default::default(),
            )
            .map_err(|e| solver_error(iteration, format!("{e:?}")))?;
        llt.solve_in_place_with_conj(
            Conj::No,
            rhs.as_mut(),
            par,
            MemStack::new(&mut solve_memory),
        );
        for (i, p) in positions.iter_mut().enumerate() {
            *p = [rhs[(i, 0)], rhs[(i, 1)], rhs[(i, 2)]];
        }
        if let Some((vertex, _)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
        {
            return Err(solver_error(
                iteration,
                format!("vertex {vertex} became non-finite"),
            ));
        }
        beta *= params.kappa;
        alpha *= params.alpha_decay;
        progress.advance(1);
    }
    progress.finish();
    Ok(mesh.with_positions(positions))
}

crate::classical_method!(L0Params, l0);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d_vanishes_on_coplanar_and_not_on_bent_pairs() {
        let flat = vec![
            [0.0, 0.0, 0.0],
            [0.3, -1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.6, 0.8, 0.0],
        ];
        let s: Stencil = [0, 1, 2, 3];
        let c = d_coefficients(&s, &flat);
        let mut dp = [0.0; 3];
        for k in 0..4 {
            dp = vec3::add(dp, vec3::scale(flat[k], c[k]));
        }
        assert!(vec3::norm(dp) < 1e-15, "{dp:?}");
        assert!((c.iter().sum::<f64>()).abs() < 1e-15);
        let mut bent = flat.clone();
        bent[3][2] = 0.5;
        let c = d_coefficients(&s, &bent);
        let mut dp = [0.0; 3];
        for k in 0..4 {
            dp = vec3::add(dp, vec3::scale(bent[k], c[k]));
        }
        assert!(vec3::norm(dp) > 0.1);
    }

    #[test]
    fn iteration_count_matches_the_paper() {
        // 0.001 · 1.414^k ≤ 1000 for k = 0..=39.
        assert_eq!(L0Params::default().iterations(), 40);
    }

    #[test]
    fn validate_names_the_field() {
        let p = L0Params {
            kappa: 1.0,
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("kappa"));
        let p = L0Params {
            lambda_over_le2: -1.0,
            ..Default::default()
        };
        assert!(
            p.validate()
                .unwrap_err()
                .to_string()
                .contains("lambda_over_le2")
        );
        // Audit: β_max 1e300 passed and the Cholesky failed mid-run.
        let p = L0Params {
            beta_max: 1e300,
            ..Default::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("beta_max") && e.contains("at most"), "{e}");
    }
}
