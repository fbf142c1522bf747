//! One vertex attribute of the primitives (`TEXCOORD_0`, `COLOR_0`, …) per
//! triangle corner of the welded mesh ([`GltfAttributes::corner_values`]).
//! Welding joins the vertices of primitives split at a UV or colour seam,
//! so a mesh vertex can have one value per primitive meeting there: the
//! honest layout is per corner, like OBJ's `f v/vt`.

use super::GltfAttributes;
use super::accessor::{self, item, uint};
use crate::error::MeshError;
use crate::io::NO_INDEX;
use serde_json::Value;
use std::collections::HashMap;
use std::path::PathBuf;

/// The values of one vertex attribute of a glTF file, per triangle corner
/// of the welded mesh: corner `k` of mesh triangle `f` has the value
/// `values[corners[f][k]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfCornerValues {
    /// the elements of the attribute's accessors, each accessor once, in
    /// the order the primitives first use them; an element has as many
    /// numbers as its accessor's type (`VEC2` 2, `VEC3` 3, `VEC4` 4).
    /// `FLOAT` components as read; normalized integer components mapped as
    /// glTF 2.0 §3.11 says (unsigned byte / short `x / 255`, `x / 65535`
    /// into 0..=1, signed `max(x / 127, −1)`, `max(x / 32767, −1)`);
    /// other integers (`KHR_mesh_quantization`) as read
    pub values: Vec<Vec<f64>>,
    /// per triangle of the mesh (len = its faces), the index into `values`
    /// of each corner, in the mesh's corner order (that of the file, turned
    /// over as the mesh's triangle is under a mirroring transform);
    /// [`NO_INDEX`] (`u32::MAX`) at the three corners of a triangle whose
    /// primitive lacks the attribute
    pub corners: Vec<[u32; 3]>,
}

impl GltfAttributes {
    /// The values of the vertex attribute `attribute` (`TEXCOORD_0`,
    /// `COLOR_0`, …) per triangle corner of the mesh, concatenated over the
    /// primitives that have it (see [`GltfCornerValues`]); `None` when no
    /// primitive read has it.
    ///
    /// # Errors
    /// [`MeshError::Parse`] (file `<glTF document>`, line 0), naming the
    /// primitive and the accessor, when an accessor of the attribute is not
    /// `VEC2`, `VEC3` or `VEC4`, is sparse or has no buffer view, lies
    /// beyond its bytes, or has another count than the primitive's
    /// `POSITION` accessor.
    ///
    /// # Performance
    /// Decodes the accessors on each call: O(elements + triangles).
    pub fn corner_values(&self, attribute: &str) -> Result<Option<GltfCornerValues>, MeshError> {
        self.gather(attribute).map_err(|message| MeshError::Parse {
            path: PathBuf::from("<glTF document>"),
            line: 0,
            message,
        })
    }

    /// Writes `values` into the accessors of vertex attribute `attribute`:
    /// the inverse of [`GltfAttributes::corner_values`], `values` holding
    /// each accessor's elements once in the same order (as
    /// [`GltfCornerValues::values`]). Floats are stored as the nearest f32,
    /// normalized integers as the nearest step of their type; an accessor's
    /// `min` / `max`, where it has them, follow, and a `data:` buffer is
    /// encoded anew. The connectivity (which corner uses which element)
    /// stays as read.
    ///
    /// # Errors
    /// [`MeshError::InvalidParameter`] (nothing written) when no primitive
    /// has the attribute, an accessor cannot be read (as `corner_values`),
    /// `values` holds another number of elements or an element another
    /// number of components than its accessor, or a value cannot be stored
    /// in its component type (not finite, out of range, not whole): the
    /// message names the attribute, the element and the accessor.
    pub fn set_corner_values(
        &mut self,
        attribute: &str,
        values: &[Vec<f64>],
    ) -> Result<(), MeshError> {
        let writes =
            self.encode(attribute, values)
                .map_err(|message| MeshError::InvalidParameter {
                    name: "glTF attribute values",
                    message: format!("{attribute}: {message}"),
                })?;
        for (index, layout, bytes) in writes {
            let buffer = &mut self.buffers[layout.buffer].bytes;
            for (at, (b, size)) in bytes {
                buffer[at..at + size].copy_from_slice(&b[..size]);
            }
            accessor::refresh_bounds(&mut self.json, buffer, index, &layout);
            if let super::GltfBufferSource::DataUri { prefix } = &self.buffers[layout.buffer].source
            {
                let uri = super::container::encode_data(prefix, &self.buffers[layout.buffer].bytes);
                if let Some(Value::Object(entry)) = self
                    .json
                    .pointer_mut(&format!("/buffers/{}", layout.buffer))
                {
                    entry.insert("uri".into(), Value::String(uri));
                }
            }
        }
        Ok(())
    }

    /// The byte writes of [`GltfAttributes::set_corner_values`], per
    /// accessor (its index, its layout, each component's offset and
    /// bytes), every value checked before anything is written.
    #[allow(clippy::type_complexity)]
    fn encode(
        &self,
        attribute: &str,
        values: &[Vec<f64>],
    ) -> Result<Vec<(usize, accessor::Layout, Vec<(usize, ([u8; 4], usize))>)>, String> {
        let lengths: Vec<usize> = self.buffers.iter().map(|b| b.bytes.len()).collect();
        let mut writes: Vec<(usize, accessor::Layout, Vec<_>)> = Vec::new();
        let mut next = 0;
        for prim in &self.primitives {
            let Some(index) = self.attribute_accessor(prim.mesh, prim.primitive, attribute)? else {
                continue;
            };
            if writes.iter().any(|(known, ..)| *known == index) {
                continue;
            }
            let what = format!("meshes[{}].primitives[{}]", prim.mesh, prim.primitive);
            let (layout, normalized) = self.vector_accessor(index, &lengths, attribute, &what)?;
            let size = accessor::component_size(layout.component_type).unwrap_or(4);
            let elements = values.get(next..next + layout.count).ok_or_else(|| {
                format!(
                    "{} elements given, the accessors hold more (accessors[{index}] has {} from \
                     element {next})",
                    values.len(),
                    layout.count
                )
            })?;
            let mut bytes = Vec::with_capacity(layout.count * layout.components);
            for (i, element) in elements.iter().enumerate() {
                if element.len() != layout.components {
                    return Err(format!(
                        "element {} has {} components, accessors[{index}] {}",
                        next + i,
                        element.len(),
                        layout.components
                    ));
                }
                for (c, &v) in element.iter().enumerate() {
                    let encoded = accessor::encode_number(layout.component_type, normalized, v)
                        .map_err(|e| format!("element {}: {e} (accessors[{index}])", next + i))?;
                    bytes.push((layout.at(i) + c * size, encoded));
                }
            }
            next += layout.count;
            writes.push((index, layout, bytes));
        }
        if writes.is_empty() {
            return Err("no primitive has it".into());
        }
        if next != values.len() {
            return Err(format!(
                "{} elements given, the accessors hold {next}",
                values.len()
            ));
        }
        Ok(writes)
    }

    fn gather(&self, attribute: &str) -> Result<Option<GltfCornerValues>, String> {
        let lengths: Vec<usize> = self.buffers.iter().map(|b| b.bytes.len()).collect();
        let mut values: Vec<Vec<f64>> = Vec::new();
        // accessor → (index of its element 0 in `values`, its elements)
        let mut first: HashMap<usize, (u32, usize)> = HashMap::new();
        let mut corners = Vec::new();
        for prim in &self.primitives {
            let what = format!("meshes[{}].primitives[{}]", prim.mesh, prim.primitive);
            let Some(index) = self.attribute_accessor(prim.mesh, prim.primitive, attribute)? else {
                corners.extend(prim.triangles.iter().map(|_| [NO_INDEX; 3]));
                continue;
            };
            let (base, len) = match first.get(&index) {
                Some(&known) => known,
                None => {
                    let elements = self.decode(index, &lengths, attribute, &what)?;
                    let (base, len) = (values.len() as u32, elements.len());
                    if !u32::try_from(values.len() + len).is_ok_and(|end| end < NO_INDEX) {
                        return Err(format!("{attribute}: more than 2^32 − 2 values"));
                    }
                    values.extend(elements);
                    first.insert(index, (base, len));
                    (base, len)
                }
            };
            // checked for every primitive: an accessor may be shared
            let count = self.positions[prim.positions].vertices.len();
            if len != count {
                return Err(format!(
                    "{what}: {attribute} accessors[{index}] has {len} elements, its POSITION has \
                     {count}"
                ));
            }
            let mirrored = self.positions[prim.positions].transform().determinant() < 0.0;
            corners.extend(prim.triangles.iter().map(|t| {
                let [a, b, c] = t.map(|e| base + e);
                if mirrored { [a, c, b] } else { [a, b, c] }
            }));
        }
        Ok((!first.is_empty()).then_some(GltfCornerValues { values, corners }))
    }

    /// The accessor of vertex attribute `name` of
    /// `meshes[mesh].primitives[primitive]`, `None` when it has none.
    fn attribute_accessor(
        &self,
        mesh: usize,
        primitive: usize,
        name: &str,
    ) -> Result<Option<usize>, String> {
        let what = format!("meshes[{mesh}].primitives[{primitive}].attributes");
        let attributes = item(&self.json, "meshes", mesh)?
            .get("primitives")
            .and_then(|p| p.get(primitive))
            .and_then(|p| p.get("attributes"))
            .and_then(Value::as_object)
            .ok_or_else(|| format!("{what} is not an object"))?;
        uint(attributes, name, &what)
    }

    /// The elements of `accessors[index]`, a `VEC2`, `VEC3` or `VEC4`
    /// accessor used as `attribute` by `what`.
    fn decode(
        &self,
        index: usize,
        lengths: &[usize],
        attribute: &str,
        what: &str,
    ) -> Result<Vec<Vec<f64>>, String> {
        let (layout, normalized) = self.vector_accessor(index, lengths, attribute, what)?;
        let buffer = &self.buffers[layout.buffer].bytes;
        Ok((0..layout.count)
            .map(|i| {
                (0..layout.components)
                    .map(|c| accessor::read_number(buffer, &layout, i, c, normalized))
                    .collect()
            })
            .collect())
    }

    /// The layout of `accessors[index]`, a `VEC2`, `VEC3` or `VEC4`
    /// accessor used as `attribute` by `what`, and whether it is
    /// normalized.
    fn vector_accessor(
        &self,
        index: usize,
        lengths: &[usize],
        attribute: &str,
        what: &str,
    ) -> Result<(accessor::Layout, bool), String> {
        let layout = accessor::layout(&self.json, lengths, index)
            .map_err(|e| format!("{what}: {attribute}: {e}"))?;
        let object = item(&self.json, "accessors", index)?;
        let kind = object.get("type").and_then(Value::as_str).unwrap_or("");
        if !["VEC2", "VEC3", "VEC4"].contains(&kind) {
            return Err(format!(
                "{what}: {attribute} accessors[{index}] has type {kind:?}, not VEC2, VEC3 or VEC4"
            ));
        }
        let normalized = object
            .get("normalized")
            .and_then(Value::as_bool)
            .unwrap_or(false);
        Ok((layout, normalized))
    }
}
