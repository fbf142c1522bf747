//! Smooth surfaces sampled by procedural shapes: new vertices made by edge
//! splits are moved onto them, so refinement samples the surface instead of
//! its first polyhedral approximation.

use normalnet_mesh::vec3::{self, Vec3};

/// A surface a face lies on.
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    /// A plane (splits keep midpoints as they are).
    Plane,
    /// A cone or cylinder about the y axis: radius `r0` at `y = y0`, `r1`
    /// at `y = y1`, linear between; centre `(cx, cz)`.
    Cone {
        /// axis x
        cx: f64,
        /// axis z
        cz: f64,
        /// lower height
        y0: f64,
        /// radius at y0
        r0: f64,
        /// upper height
        y1: f64,
        /// radius at y1
        r1: f64,
    },
    /// A ruled height field `y = base + amp · sin(freq · x + phase) + slope · x`
    /// (straight lines along z).
    Ruled {
        /// base height
        base: f64,
        /// amplitude
        amp: f64,
        /// angular frequency along x
        freq: f64,
        /// phase
        phase: f64,
        /// linear slope along x
        slope: f64,
    },
    /// A star-shaped blob about the origin: `|p| = ρ(p/|p|)`,
    /// `ρ(d) = 1 + Σ a_i sin(w_i (d · u_i) + φ_i)`.
    Blob {
        /// centre
        centre: Vec3,
        /// `(a_i, w_i, u_i, φ_i)`
        terms: Vec<(f64, f64, Vec3, f64)>,
    },
}

impl Surface {
    /// Moves `p` onto the surface (approximately the closest point).
    pub fn project(&self, p: Vec3) -> Vec3 {
        match self {
            Surface::Plane => p,
            Surface::Cone {
                cx,
                cz,
                y0,
                r0,
                y1,
                r1,
            } => {
                let t = ((p[1] - y0) / (y1 - y0)).clamp(0.0, 1.0);
                let r = r0 + (r1 - r0) * t;
                let (dx, dz) = (p[0] - cx, p[2] - cz);
                let l = (dx * dx + dz * dz).sqrt();
                if l < 1e-12 {
                    p
                } else {
                    [cx + dx * r / l, p[1], cz + dz * r / l]
                }
            }
            Surface::Ruled { .. } => [p[0], self.height(p[0]), p[2]],
            Surface::Blob { centre, .. } => {
                let d = vec3::normalize_or_zero(vec3::sub(p, *centre));
                if d == [0.0; 3] {
                    p
                } else {
                    vec3::add(*centre, vec3::scale(d, self.radius(d)))
                }
            }
        }
    }

    /// The same surface moved by `t`.
    pub fn translated(&self, t: Vec3) -> Surface {
        match self.clone() {
            Surface::Plane => Surface::Plane,
            Surface::Cone {
                cx,
                cz,
                y0,
                r0,
                y1,
                r1,
            } => Surface::Cone {
                cx: cx + t[0],
                cz: cz + t[2],
                y0: y0 + t[1],
                r0,
                y1: y1 + t[1],
                r1,
            },
            Surface::Ruled {
                base,
                amp,
                freq,
                phase,
                slope,
            } => Surface::Ruled {
                base: base + t[1] - slope * t[0],
                amp,
                freq,
                phase: phase - freq * t[0],
                slope,
            },
            Surface::Blob { centre, terms } => Surface::Blob {
                centre: vec3::add(centre, t),
                terms,
            },
        }
    }

    /// Height of a [`Surface::Ruled`] at `x` (0 for other surfaces).
    pub fn height(&self, x: f64) -> f64 {
        match self {
            Surface::Ruled {
                base,
                amp,
                freq,
                phase,
                slope,
            } => base + amp * (freq * x + phase).sin() + slope * x,
            _ => 0.0,
        }
    }

    /// Radius of a [`Surface::Blob`] in direction `d` (1 for other surfaces).
    pub fn radius(&self, d: Vec3) -> f64 {
        match self {
            Surface::Blob { terms, .. } => {
                1.0 + terms
                    .iter()
                    .map(|(a, w, u, ph)| a * (w * vec3::dot(d, *u) + ph).sin())
                    .sum::<f64>()
            }
            _ => 1.0,
        }
    }
}
