//! Procedural CAD-like training shapes (SPEC §8 "procedural CAD-like shapes
//! (boxes, cylinders, cones, bevelled and notched solids, irregularly
//! triangulated)").
//!
//! Every shape is built as a coarse closed polyhedron ([`build`]): a loft of
//! 2D profiles (boxes, prisms over n-gons, stars, L and cross shapes,
//! notched rectangles; chamfered and filleted rims; cylinders and cones;
//! a fandisk-like ruled top joined to its walls by sharp creases), a
//! displaced icosahedron (smooth blob), or several parts placed side by side
//! without intersection. It is then refined ([`edit`]) by longest-edge
//! bisection to a target edge length that varies over the shape (denser
//! spots), each new vertex moved onto the smooth surface it samples, and
//! made irregular by Delaunay flips followed by random flips and in-plane
//! vertex jitter where they keep the surface. The result is rotated at
//! random. Sharp edges stay mesh edges: splits never move a crease and
//! flips never cross one.
//!
//! Output: a closed, edge-manifold, consistently outward-oriented mesh with
//! no degenerate face (smallest angle ≥ 1°, checked), about `target_faces`
//! faces (within ~25 %), deterministic for a given seed.

pub mod build;
pub mod edit;
pub mod surface;

use crate::error::VoxelError;
use build::{ConvexPolyhedron, Ring, cone_surface, loft, ring};
use edit::EditMesh;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Topology};
use rand::seq::IndexedRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, TAU};
use surface::Surface;

/// The kinds of procedural shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShapeKind {
    /// A box with random proportions.
    Box,
    /// A cylinder.
    Cylinder,
    /// A cone or a truncated cone (frustum).
    Cone,
    /// A prism over an n-gon, a star, an L or a cross.
    Prism,
    /// A box or prism with chamfered top and bottom rims.
    Chamfered,
    /// A box or prism with a rounded (filleted) top rim and a chamfered base.
    Bevelled,
    /// A block with rectangular notches (slots) cut through it.
    Notched,
    /// A fandisk-like block: a ruled wavy top meeting flat walls at creases.
    Ruled,
    /// A smooth blob (displaced sphere).
    Blob,
    /// Two or three of the other kinds placed side by side.
    Union,
    /// A convex polyhedron cut by 6–20 random planes: flat facets meeting at
    /// obtuse edges, like a randomised dodecahedron (named only: not in
    /// [`ALL_KINDS`]).
    Polyhedron,
}

/// Kinds made only when asked for by name (`normalnet shapes --kind`),
/// outside the seed cycle of [`ALL_KINDS`], so that every `shape:N` training
/// source keeps its shape.
pub const NAMED_KINDS: [ShapeKind; 1] = [ShapeKind::Polyhedron];

/// The kinds of the seed cycle, in the order [`ShapeKind::from_seed`] cycles
/// through them.
pub const ALL_KINDS: [ShapeKind; 10] = [
    ShapeKind::Box,
    ShapeKind::Cylinder,
    ShapeKind::Cone,
    ShapeKind::Prism,
    ShapeKind::Chamfered,
    ShapeKind::Bevelled,
    ShapeKind::Notched,
    ShapeKind::Ruled,
    ShapeKind::Blob,
    ShapeKind::Union,
];

impl ShapeKind {
    /// The kind for a seed: `ALL_KINDS[seed % 10]`.
    pub fn from_seed(seed: u64) -> ShapeKind {
        ALL_KINDS[(seed % ALL_KINDS.len() as u64) as usize]
    }

    /// Lower-case name (`box`, `cylinder`, …).
    pub fn name(&self) -> &'static str {
        match self {
            ShapeKind::Box => "box",
            ShapeKind::Cylinder => "cylinder",
            ShapeKind::Cone => "cone",
            ShapeKind::Prism => "prism",
            ShapeKind::Chamfered => "chamfered",
            ShapeKind::Bevelled => "bevelled",
            ShapeKind::Notched => "notched",
            ShapeKind::Ruled => "ruled",
            ShapeKind::Blob => "blob",
            ShapeKind::Union => "union",
            ShapeKind::Polyhedron => "polyhedron",
        }
    }

    /// The kind called `name`.
    ///
    /// # Errors
    /// [`VoxelError::InvalidParameter`] naming `kind`.
    pub fn from_name(name: &str) -> Result<ShapeKind, VoxelError> {
        let kinds = || ALL_KINDS.into_iter().chain(NAMED_KINDS);
        kinds()
            .find(|k| k.name() == name)
            .ok_or_else(|| VoxelError::InvalidParameter {
                name: "kind",
                message: format!(
                    "unknown shape kind {name:?} (expected one of {})",
                    kinds().map(|k| k.name()).collect::<Vec<_>>().join(", ")
                ),
            })
    }
}

/// Default face count of [`generate`] callers (CLI `--faces`).
pub const DEFAULT_FACES: usize = 4000;

/// A shape of kind `ShapeKind::from_seed(seed)` (see [`generate`]).
///
/// # Errors
/// As [`generate`].
pub fn generate_seeded(seed: u64, target_faces: usize) -> Result<Mesh, VoxelError> {
    generate(ShapeKind::from_seed(seed), seed, target_faces)
}

/// A seeded shape ([`generate_seeded`]) and its copy with the default
/// Gaussian noise ([`normalnet_mesh::NoiseParams`]) of `level` × the mean
/// edge length, drawn with `noise_seed`: `(clean, noisy)`, the pair a test
/// or benchmark of a denoiser starts from.
///
/// # Errors
/// As [`generate`], and [`VoxelError::Mesh`] for a noise level out of range.
pub fn noisy_pair(
    seed: u64,
    target_faces: usize,
    level: f64,
    noise_seed: u64,
) -> Result<(Mesh, Mesh), VoxelError> {
    let clean = generate_seeded(seed, target_faces)?;
    let noise = normalnet_mesh::NoiseParams {
        level,
        seed: noise_seed,
        ..normalnet_mesh::NoiseParams::default()
    };
    let noisy = normalnet_mesh::add_noise(&clean, &noise)?;
    Ok((clean, noisy))
}

/// Generates a shape of `kind` with about `target_faces` faces (100 to
/// 2,000,000), deterministic for `seed`.
///
/// # Errors
/// [`VoxelError::InvalidParameter`] for a face count out of range;
/// [`VoxelError::InvalidShape`] if the result fails the closed-manifold,
/// orientation or degeneracy checks (a generator bug; never expected).
pub fn generate(kind: ShapeKind, seed: u64, target_faces: usize) -> Result<Mesh, VoxelError> {
    if !(100..=2_000_000).contains(&target_faces) {
        return Err(VoxelError::InvalidParameter {
            name: "target_faces",
            message: format!("{target_faces} must be in 100..=2000000"),
        });
    }
    // Edge length for the target: about 1.9 faces per s² of area with this
    // refinement; corrected once from the first result.
    let coarse = build_coarse(kind, seed, 0.1);
    let mut s = (coarse.area() / (target_faces as f64 / 1.9)).sqrt();
    let mut mesh = finish(build_coarse(kind, seed, s), seed, s);
    for _ in 0..4 {
        let ratio = mesh.faces.len() as f64 / target_faces as f64;
        if (0.85..=1.15).contains(&ratio) {
            break;
        }
        s *= ratio.sqrt();
        mesh = finish(build_coarse(kind, seed, s), seed, s);
    }
    validate(&mesh).map_err(|message| VoxelError::InvalidShape {
        kind: kind.name().into(),
        seed,
        message,
    })?;
    Ok(Mesh::new(mesh.positions, mesh.faces)?)
}

fn validate(m: &EditMesh) -> Result<(), String> {
    if !m.is_closed_manifold() {
        return Err("not a closed edge-manifold mesh".into());
    }
    let topo = Topology::new(m.positions.len(), &m.faces);
    if topo.num_boundary_edges() != 0 || !topo.non_manifold_edges().is_empty() {
        return Err("topology reports boundary or non-manifold edges".into());
    }
    if m.signed_volume6() <= 0.0 {
        return Err("not outward oriented".into());
    }
    let (min_angle, _) = m.quality();
    if min_angle < 1.0 {
        return Err(format!("smallest angle {min_angle:.3}° < 1°"));
    }
    Ok(())
}

/// Refines, flips, jitters and rotates a coarse shape.
fn finish(mut m: EditMesh, seed: u64, s: f64) -> EditMesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_f1ee);
    let (lo, hi) = m.bounds();
    let size = vec3::norm(vec3::sub(hi, lo));
    // Denser spots: the target edge shrinks to ~45 % near 0–3 random points.
    let spots: Vec<Vec3> = (0..rng.random_range(0..=3))
        .map(|_| [0, 1, 2].map(|a| rng.random_range(lo[a]..=hi[a])))
        .collect();
    let radius = 0.25 * size;
    let target = |p: Vec3| {
        let near = spots
            .iter()
            .map(|c| (-vec3::dist2(p, *c) / (radius * radius)).exp())
            .fold(0.0, f64::max);
        s * (1.0 - 0.55 * near)
    };
    m.refine(target, 4_000_000);
    m.delaunay_flips(10);
    m.random_flips(rng.random_range(0.05..0.3), 20.0, &mut rng);
    m.jitter_planar(rng.random_range(0.1..0.35), 15.0, &mut rng);
    if m.signed_volume6() < 0.0 {
        m.flip_orientation();
    }
    // Random rotation and centring.
    let centre = vec3::scale(vec3::add(lo, hi), 0.5);
    let r = random_rotation(&mut rng);
    m.transform(|p| {
        let q = vec3::sub(p, centre);
        [vec3::dot(r[0], q), vec3::dot(r[1], q), vec3::dot(r[2], q)]
    });
    m
}

fn random_rotation(rng: &mut ChaCha8Rng) -> [[f64; 3]; 3] {
    // Uniform rotation from a random unit quaternion.
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (w, x, y, z) = (
        a * (TAU * u2).sin(),
        a * (TAU * u2).cos(),
        b * (TAU * u3).sin(),
        b * (TAU * u3).cos(),
    );
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// The coarse polyhedron of a shape; `s` (target edge length) sets the
/// number of sides of round profiles.
fn build_coarse(kind: ShapeKind, seed: u64, s: f64) -> EditMesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut m = EditMesh::new();
    build_part(&mut m, kind, &mut rng, s);
    m
}

/// 6–20 planes 0.45–0.55 from the centre with normals at least 25° apart,
/// drawn again until the polyhedron they cut has no edge shorter than 0.05
/// and every facet corner within 15–160° (needles and slivers would stay
/// after refinement);
/// a cube if a thousand draws fail.
fn polyhedron(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let min_cos = 25f64.to_radians().cos();
    for _ in 0..1000 {
        let count = rng.random_range(6..=20);
        let mut normals: Vec<Vec3> = Vec::with_capacity(count);
        for _ in 0..100 * count {
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi = rng.random_range(0.0..TAU);
            let r = (1.0 - z * z).sqrt();
            let n = [r * phi.cos(), r * phi.sin(), z];
            if normals.iter().all(|&o| vec3::dot(o, n) < min_cos) {
                normals.push(n);
                if normals.len() == count {
                    break;
                }
            }
        }
        let planes: Vec<(Vec3, f64)> = normals
            .iter()
            .map(|&n| (n, rng.random_range(0.45..0.55)))
            .collect();
        if let Some(p) = ConvexPolyhedron::from_planes(&planes) {
            let (smallest, largest) = p.corner_angles();
            if p.shortest_edge() >= 0.05 && smallest >= 15.0 && largest <= 160.0 {
                p.add_to(m);
                return;
            }
        }
    }
    build::prism(m, &build::rect(0.8, 0.8), [0.0, 0.0], 0.8);
}

/// The centre of every part's profile.
const ORIGIN: [f64; 2] = [0.0, 0.0];

fn round_sides(r: f64, s: f64) -> usize {
    ((TAU * r / s).ceil() as usize).clamp(12, 2000)
}

/// Adds one part of `kind` to `m` (`s`: the target edge length of round sides).
fn build_part(m: &mut EditMesh, kind: ShapeKind, rng: &mut ChaCha8Rng, s: f64) {
    match kind {
        ShapeKind::Box => box_part(m, rng),
        ShapeKind::Cylinder => cylinder(m, rng, s),
        ShapeKind::Cone => cone(m, rng, s),
        ShapeKind::Prism => prism_part(m, rng),
        ShapeKind::Chamfered => chamfered(m, rng),
        ShapeKind::Bevelled => bevelled(m, rng),
        ShapeKind::Notched => notched(m, rng),
        ShapeKind::Ruled => ruled(m, rng),
        ShapeKind::Blob => blob(m, rng),
        ShapeKind::Polyhedron => polyhedron(m, rng),
        ShapeKind::Union => union(m, rng, s),
    }
}

/// A box.
fn box_part(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let p = build::rect(rng.random_range(0.3..1.0), rng.random_range(0.3..1.0));
    let h = rng.random_range(0.3..1.0);
    build::prism(m, &p, o, h);
}

/// A cylinder: its side on the cone surface of equal radii.
fn cylinder(m: &mut EditMesh, rng: &mut ChaCha8Rng, s: f64) {
    let o = ORIGIN;
    let r = rng.random_range(0.2..0.5);
    let h = rng.random_range(0.3..1.2);
    let p = build::ngon(round_sides(r, s), r, 0.0);
    let side = m.add_surface(cone_surface(o, 0.0, r, h, r));
    loft(
        m,
        &[ring(&p, 1.0, o, 0.0, side), ring(&p, 1.0, o, h, 0)],
        &p,
        0,
        None,
        |q| q,
    );
}

/// A cone, pointed (40 %) or cut off.
fn cone(m: &mut EditMesh, rng: &mut ChaCha8Rng, s: f64) {
    let o = ORIGIN;
    let r = rng.random_range(0.25..0.5);
    let h = rng.random_range(0.3..1.0);
    let p = build::ngon(round_sides(r, s), r, 0.0);
    if rng.random_bool(0.4) {
        let side = m.add_surface(cone_surface(o, 0.0, r, h, 0.0));
        loft(
            m,
            &[ring(&p, 1.0, o, 0.0, side)],
            &p,
            0,
            Some([0.0, h, 0.0]),
            |q| q,
        );
    } else {
        let t = rng.random_range(0.25..0.75);
        let side = m.add_surface(cone_surface(o, 0.0, r, h, r * t));
        loft(
            m,
            &[ring(&p, 1.0, o, 0.0, side), ring(&p, t, o, h, 0)],
            &p,
            0,
            None,
            |q| q,
        );
    }
}

/// A prism over a polygon, star, L or cross.
fn prism_part(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let p = match rng.random_range(0..4) {
        0 => build::ngon(
            rng.random_range(3..9),
            rng.random_range(0.3..0.5),
            rng.random_range(0.0..TAU),
        ),
        1 => build::star(
            rng.random_range(4..8),
            0.5,
            rng.random_range(0.25..0.4),
            rng.random_range(0.0..TAU),
        ),
        2 => build::l_shape(rng.random_range(0.3..0.6)),
        _ => build::cross_shape(rng.random_range(0.15..0.35)),
    };
    let h = rng.random_range(0.2..1.0);
    build::prism(m, &p, o, h);
}

/// A prism over a rectangle or polygon with chamfered top and bottom edges.
fn chamfered(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let (w, d) = (rng.random_range(0.4..1.0), rng.random_range(0.4..1.0));
    let p = match rng.random_range(0..3) {
        0 => build::rect(w, d),
        1 => build::chamfered_rect(w, d, rng.random_range(0.05..0.3) * w.min(d)),
        _ => build::ngon(rng.random_range(5..9), w / 2.0, 0.0),
    };
    let h = rng.random_range(0.3..0.9);
    let c = rng.random_range(0.05..0.15);
    let k = 1.0 - 2.0 * c / w.min(d);
    let rings = [
        ring(&p, k, o, 0.0, 0),
        ring(&p, 1.0, o, c, 0),
        ring(&p, 1.0, o, h - c, 0),
        ring(&p, k, o, h, 0),
    ];
    loft(m, &rings, &p, 0, None, |q| q);
}

/// A prism with a chamfered foot and a rounded top edge.
fn bevelled(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let (w, d) = (rng.random_range(0.5..1.0), rng.random_range(0.5..1.0));
    let p = match rng.random_range(0..2) {
        0 => build::rounded_rect(w, d, rng.random_range(0.05..0.2), 4),
        _ => build::rect(w, d),
    };
    let h = rng.random_range(0.4..0.9);
    let r = rng.random_range(0.08..0.18);
    let c = rng.random_range(0.03..0.1);
    let scale = |delta: f64| 1.0 - 2.0 * delta / w.min(d);
    let mut rings: Vec<Ring> = vec![ring(&p, scale(c), o, 0.0, 0), ring(&p, 1.0, o, c, 0)];
    let steps = 5;
    for i in 0..=steps {
        let t = FRAC_PI_2 * i as f64 / steps as f64;
        rings.push(ring(
            &p,
            scale(r * (1.0 - t.cos())),
            o,
            h - r + r * t.sin(),
            0,
        ));
    }
    loft(m, &rings, &p, 0, None, |q| q);
}

/// A rectangle with one to three notches, extruded.
fn notched(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let (w, d) = (rng.random_range(0.6..1.2), rng.random_range(0.4..0.8));
    let count = rng.random_range(1..=3);
    let slot = w / (2 * count + 1) as f64;
    let notches: Vec<(f64, f64, f64)> = (0..count)
        .map(|i| {
            let cx = -w / 2.0 + slot * (2 * i + 1) as f64 + slot / 2.0;
            (
                cx,
                slot * rng.random_range(0.5..0.95),
                d * rng.random_range(0.2..0.6),
            )
        })
        .collect();
    let p = build::notched_rect(w, d, &notches);
    let h = rng.random_range(0.2..0.6);
    build::prism(m, &p, o, h);
}

/// A prism whose top is a ruled wave (a height field).
fn ruled(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let o = ORIGIN;
    let (w, d) = (rng.random_range(0.6..1.2), rng.random_range(0.4..0.9));
    let p = match rng.random_range(0..2) {
        0 => build::rect(w, d),
        _ => build::chamfered_rect(w, d, rng.random_range(0.1..0.3) * d),
    };
    let h = rng.random_range(0.4..0.8);
    let top = Surface::Ruled {
        base: h,
        amp: rng.random_range(0.05..0.2) * h,
        freq: rng.random_range(2.0..8.0),
        phase: rng.random_range(0.0..TAU),
        slope: rng.random_range(-0.3..0.3),
    };
    // Splits of the wall tops move onto the wave (a height field:
    // vertical moves keep the triangulation valid).
    let tag = m.add_surface(top.clone());
    loft(
        m,
        &[ring(&p, 1.0, o, 0.0, 0), ring(&p, 1.0, o, h, 0)],
        &p,
        tag,
        None,
        |q| [q[0], top.height(q[0]), q[2]],
    );
}

/// A smooth blob: an icosphere projected onto a sum of waves over the sphere.
fn blob(m: &mut EditMesh, rng: &mut ChaCha8Rng) {
    let terms = (0..rng.random_range(3..6))
        .map(|_| {
            let u = vec3::normalize_or_zero([0; 3].map(|_| rng.random_range(-1.0..1.0)));
            let u = if u == [0.0; 3] { [0.0, 1.0, 0.0] } else { u };
            (
                rng.random_range(0.04..0.14),
                rng.random_range(1.5..4.0),
                u,
                rng.random_range(0.0..TAU),
            )
        })
        .collect();
    let tag = m.add_surface(Surface::Blob {
        centre: [0.0; 3],
        terms,
    });
    let first = m.positions.len();
    build::icosahedron(m, tag);
    for v in first..m.positions.len() {
        let p = m.positions[v];
        m.positions[v] = m.surfaces[tag as usize].project(p);
    }
}

/// Two or three parts of the other kinds side by side, touching or not.
fn union(m: &mut EditMesh, rng: &mut ChaCha8Rng, s: f64) {
    let parts = rng.random_range(2..=3);
    let kinds = [
        ShapeKind::Box,
        ShapeKind::Cylinder,
        ShapeKind::Cone,
        ShapeKind::Prism,
        ShapeKind::Chamfered,
        ShapeKind::Bevelled,
        ShapeKind::Notched,
        ShapeKind::Ruled,
    ];
    let mut x = 0.0;
    for _ in 0..parts {
        let kind = *kinds.choose(rng).expect("non-empty");
        let mut part = EditMesh::new();
        build_part(&mut part, kind, rng, s);
        let (lo, hi) = part.bounds();
        let gap = rng.random_range(0.05..0.3);
        part.translate([
            x - lo[0],
            rng.random_range(-0.2..0.2) - lo[1],
            rng.random_range(-0.3..0.3),
        ]);
        x += hi[0] - lo[0] + gap;
        m.append(&part);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for k in ALL_KINDS {
            assert_eq!(ShapeKind::from_name(k.name()).unwrap(), k);
        }
        assert!(
            ShapeKind::from_name("torus")
                .unwrap_err()
                .to_string()
                .contains("kind")
        );
        assert!(generate(ShapeKind::Box, 0, 10).is_err());
    }
}
