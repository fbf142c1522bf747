//! Accessors and buffer views (glTF 2.0 §3.6 "Binary Data Storage"): where
//! an accessor's elements lie in a buffer, checked against the bytes there
//! are, and the element readers and writers of the few layouts this crate
//! touches (`VEC3` of `FLOAT`, `SCALAR` indices, and any component as a
//! number, normalized or not, for [`super::corners`]).

use serde_json::{Map, Value};

/// `componentType` of 32-bit floats.
pub(crate) const FLOAT: u64 = 5126;
/// `componentType` of signed bytes and shorts.
pub(crate) const BYTE: u64 = 5120;
pub(crate) const SHORT: u64 = 5122;
/// `componentType` of unsigned bytes, shorts and ints (the index types).
pub(crate) const UNSIGNED_BYTE: u64 = 5121;
pub(crate) const UNSIGNED_SHORT: u64 = 5123;
pub(crate) const UNSIGNED_INT: u64 = 5125;

/// The bytes of a component type, `None` for a type glTF does not define.
pub(crate) fn component_size(component_type: u64) -> Option<usize> {
    match component_type {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

/// The components of an accessor `type`.
fn components(kind: &str) -> Option<usize> {
    match kind {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" | "MAT2" => Some(4),
        "MAT3" => Some(9),
        "MAT4" => Some(16),
        _ => None,
    }
}

/// The array `name` of the document's root (empty when absent).
pub(crate) fn root_array<'a>(json: &'a Value, name: &str) -> Result<&'a [Value], String> {
    match json.get(name) {
        None => Ok(&[]),
        Some(Value::Array(items)) => Ok(items),
        Some(_) => Err(format!("{name} is not an array")),
    }
}

/// Item `index` of the root array `name` (`meshes`, `accessors`, …), which
/// must be an object.
pub(crate) fn item<'a>(
    json: &'a Value,
    name: &str,
    index: usize,
) -> Result<&'a Map<String, Value>, String> {
    let items = root_array(json, name)?;
    match items.get(index) {
        Some(Value::Object(o)) => Ok(o),
        Some(_) => Err(format!("{name}[{index}] is not an object")),
        None => Err(format!(
            "{name}[{index}] does not exist (the file has {} {name})",
            items.len()
        )),
    }
}

/// The non-negative integer `key` of `object` (`what` names the object in
/// the error), `None` when absent.
pub(crate) fn uint(
    object: &Map<String, Value>,
    key: &str,
    what: &str,
) -> Result<Option<usize>, String> {
    match object.get(key) {
        None => Ok(None),
        Some(v) => v
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .map(Some)
            .ok_or_else(|| format!("{what}.{key} is {v}, not a non-negative integer")),
    }
}

/// Where an accessor's elements lie: element `i` starts at byte
/// `offset + i · stride` of buffer `buffer`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    /// the buffer holding the elements
    pub buffer: usize,
    /// byte offset of element 0 in the buffer
    pub offset: usize,
    /// bytes from one element to the next
    pub stride: usize,
    /// number of elements
    pub count: usize,
    /// `componentType`
    pub component_type: u64,
    /// components per element (3 for `VEC3`)
    pub components: usize,
}

impl Layout {
    /// Byte offset of element `i` in the buffer.
    pub(crate) fn at(&self, i: usize) -> usize {
        self.offset + i * self.stride
    }
}

/// The layout of `accessors[index]`, checked: the accessor is dense (not
/// sparse) and stored in a buffer view (not implicit zeros), its buffer
/// view lies within its buffer's bytes (`buffer_lengths`) and every element
/// within the view. Errors name the accessor or view.
pub(crate) fn layout(
    json: &Value,
    buffer_lengths: &[usize],
    index: usize,
) -> Result<Layout, String> {
    let what = format!("accessors[{index}]");
    let accessor = item(json, "accessors", index)?;
    if accessor.contains_key("sparse") {
        return Err(format!(
            "{what} is sparse (sparse accessors are not supported)"
        ));
    }
    let view_index = uint(accessor, "bufferView", &what)?
        .ok_or_else(|| format!("{what} has no bufferView (implicit zeros are not supported)"))?;
    let component_type = accessor
        .get("componentType")
        .and_then(Value::as_u64)
        .ok_or_else(|| format!("{what} has no componentType"))?;
    let size = component_size(component_type).ok_or_else(|| {
        format!("{what} has componentType {component_type}, which glTF does not define")
    })?;
    let kind = accessor.get("type").and_then(Value::as_str).unwrap_or("");
    let n = components(kind)
        .ok_or_else(|| format!("{what} has type {kind:?}, which glTF does not define"))?;
    let count = uint(accessor, "count", &what)?.ok_or_else(|| format!("{what} has no count"))?;
    let accessor_offset = uint(accessor, "byteOffset", &what)?.unwrap_or(0);

    let view_what = format!("bufferViews[{view_index}]");
    let view = item(json, "bufferViews", view_index)?;
    if view
        .get("extensions")
        .is_some_and(|e| e.get("EXT_meshopt_compression").is_some())
    {
        return Err(format!(
            "{view_what} (of {what}) is compressed with EXT_meshopt_compression, which is not supported"
        ));
    }
    let buffer =
        uint(view, "buffer", &view_what)?.ok_or_else(|| format!("{view_what} has no buffer"))?;
    let view_offset = uint(view, "byteOffset", &view_what)?.unwrap_or(0);
    let view_length = uint(view, "byteLength", &view_what)?
        .ok_or_else(|| format!("{view_what} has no byteLength"))?;
    let element = size * n;
    let stride = uint(view, "byteStride", &view_what)?.unwrap_or(element);
    if stride < element {
        return Err(format!(
            "{view_what} has byteStride {stride}, less than the {element} bytes of an element of {what}"
        ));
    }
    let buffer_length = *buffer_lengths.get(buffer).ok_or_else(|| {
        format!(
            "{view_what} refers to buffers[{buffer}], the file has {}",
            buffer_lengths.len()
        )
    })?;
    let view_end = view_offset.checked_add(view_length);
    if view_end.is_none_or(|end| end > buffer_length) {
        return Err(format!(
            "{view_what} (bytes {view_offset} + {view_length}) runs past the end of buffers[{buffer}] \
             ({buffer_length} bytes)"
        ));
    }
    let end = match count {
        0 => Some(accessor_offset),
        _ => (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(accessor_offset))
            .and_then(|x| x.checked_add(element)),
    };
    if end.is_none_or(|end| end > view_length) {
        return Err(format!(
            "{what} ({count} elements of {element} bytes, stride {stride}, from byte {accessor_offset}) \
             is out of range: {view_what} has {view_length} bytes"
        ));
    }
    Ok(Layout {
        buffer,
        offset: view_offset + accessor_offset,
        stride,
        count,
        component_type,
        components: n,
    })
}

/// Element `i` of a `VEC3` `FLOAT` accessor.
pub(crate) fn read_vec3(buffer: &[u8], layout: &Layout, i: usize) -> [f32; 3] {
    let at = layout.at(i);
    std::array::from_fn(|c| {
        let b = &buffer[at + 4 * c..at + 4 * c + 4];
        f32::from_le_bytes([b[0], b[1], b[2], b[3]])
    })
}

/// Writes element `i` of a `VEC3` `FLOAT` accessor.
pub(crate) fn write_vec3(buffer: &mut [u8], layout: &Layout, i: usize, v: [f32; 3]) {
    let at = layout.at(i);
    for (c, x) in v.iter().enumerate() {
        buffer[at + 4 * c..at + 4 * c + 4].copy_from_slice(&x.to_le_bytes());
    }
}

/// Element `i` of an index accessor (`UNSIGNED_BYTE`, `_SHORT` or `_INT`).
pub(crate) fn read_index(buffer: &[u8], layout: &Layout, i: usize) -> u32 {
    let at = layout.at(i);
    match layout.component_type {
        UNSIGNED_BYTE => buffer[at] as u32,
        UNSIGNED_SHORT => u16::from_le_bytes([buffer[at], buffer[at + 1]]) as u32,
        _ => u32::from_le_bytes([buffer[at], buffer[at + 1], buffer[at + 2], buffer[at + 3]]),
    }
}

/// Component `c` of element `i`, as a number: a float as read, an integer
/// as read or, `normalized`, mapped as glTF 2.0 §3.11 says (unsigned
/// `x / max` into 0..=1, signed `max(x / max, −1)` into −1..=1, `max` the
/// largest value of the type).
pub(crate) fn read_number(
    buffer: &[u8],
    layout: &Layout,
    i: usize,
    c: usize,
    normalized: bool,
) -> f64 {
    let size = component_size(layout.component_type).unwrap_or(4);
    let at = layout.at(i) + c * size;
    let b = &buffer[at..at + size];
    let (x, max) = match layout.component_type {
        FLOAT => return f32::from_le_bytes([b[0], b[1], b[2], b[3]]).into(),
        BYTE => (f64::from(b[0] as i8), f64::from(i8::MAX)),
        UNSIGNED_BYTE => (f64::from(b[0]), f64::from(u8::MAX)),
        SHORT => (
            f64::from(i16::from_le_bytes([b[0], b[1]])),
            f64::from(i16::MAX),
        ),
        UNSIGNED_SHORT => (
            f64::from(u16::from_le_bytes([b[0], b[1]])),
            f64::from(u16::MAX),
        ),
        _ => (
            f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            f64::from(u32::MAX),
        ),
    };
    if normalized { (x / max).max(-1.0) } else { x }
}

/// The bytes (little-endian, `size` of them) that store the number `v`
/// as a component of `component_type`: the inverse of [`read_number`]. A
/// float as the nearest f32; a `normalized` integer as the nearest step
/// (`round(v · max)`, `v` within 0..=1 unsigned, −1..=1 signed); another
/// integer as it is, which must be whole. An error says why `v` cannot be
/// stored (not finite, out of the type's range, not whole).
pub(crate) fn encode_number(
    component_type: u64,
    normalized: bool,
    v: f64,
) -> Result<([u8; 4], usize), String> {
    if !v.is_finite() {
        return Err(format!("{v} is not finite"));
    }
    // `min ..= max` the type's range; normalized values map onto
    // `−max ..= max` (signed) or `0 ..= max`
    let int = |min: f64, max: f64, bits: fn(f64) -> ([u8; 4], usize)| {
        if normalized {
            let lo = if min < 0.0 { -1.0 } else { 0.0 };
            if !(lo..=1.0).contains(&v) {
                return Err(format!("{v} is outside the normalized range {lo}..=1"));
            }
            Ok(bits((v * max).round()))
        } else if v.fract() != 0.0 || !(min..=max).contains(&v) {
            Err(format!("{v} is not a whole number within {min}..={max}"))
        } else {
            Ok(bits(v))
        }
    };
    fn pad(b: &[u8]) -> ([u8; 4], usize) {
        let mut out = [0; 4];
        out[..b.len()].copy_from_slice(b);
        (out, b.len())
    }
    match component_type {
        FLOAT if v.abs() <= f64::from(f32::MAX) => Ok(((v as f32).to_le_bytes(), 4)),
        FLOAT => Err(format!("{v} is beyond the range of a 32-bit float")),
        BYTE => int(-128.0, 127.0, |x| pad(&(x as i8).to_le_bytes())),
        UNSIGNED_BYTE => int(0.0, 255.0, |x| pad(&(x as u8).to_le_bytes())),
        SHORT => int(-32768.0, 32767.0, |x| pad(&(x as i16).to_le_bytes())),
        UNSIGNED_SHORT => int(0.0, 65535.0, |x| pad(&(x as u16).to_le_bytes())),
        _ => int(0.0, f64::from(u32::MAX), |x| pad(&(x as u32).to_le_bytes())),
    }
}

/// Sets `accessors[index].min` / `.max`, where the accessor has them, to
/// the component-wise bounds of its elements as stored (integers as the
/// stored integers, glTF 2.0 §5.1.1).
pub(crate) fn refresh_bounds(json: &mut Value, buffer: &[u8], index: usize, layout: &Layout) {
    let Some(Value::Object(a)) = json.get_mut("accessors").and_then(|a| a.get_mut(index)) else {
        return;
    };
    if !a.contains_key("min") || !a.contains_key("max") || layout.count == 0 {
        return;
    }
    let number = |x: f64| match layout.component_type {
        FLOAT => json_f32(x as f32),
        _ => Value::from(x as i64),
    };
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for c in 0..layout.components {
        let values = (0..layout.count).map(|i| read_number(buffer, layout, i, c, false));
        let (min, max) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        lo.push(number(min));
        hi.push(number(max));
    }
    a.insert("min".into(), Value::Array(lo));
    a.insert("max".into(), Value::Array(hi));
}

/// An f32 as the JSON number with the fewest digits that reads back to it
/// (`0.1`, not `0.10000000149011612`).
pub(crate) fn json_f32(x: f32) -> Value {
    let shortest: f64 = x.to_string().parse().unwrap_or(x as f64);
    serde_json::Number::from_f64(shortest).map_or(Value::Null, Value::Number)
}

/// Sets `accessors[index].min` / `.max` to the component-wise bounds of
/// `values` (left alone when `values` is empty).
pub(crate) fn set_bounds(json: &mut Value, index: usize, values: &[[f32; 3]]) {
    if values.is_empty() {
        return;
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for v in values {
        for c in 0..3 {
            lo[c] = lo[c].min(v[c]);
            hi[c] = hi[c].max(v[c]);
        }
    }
    if let Some(Value::Object(a)) = json.get_mut("accessors").and_then(|a| a.get_mut(index)) {
        a.insert("min".into(), Value::Array(lo.map(json_f32).to_vec()));
        a.insert("max".into(), Value::Array(hi.map(json_f32).to_vec()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layout of one element of `components` components of `component_type`
    /// at byte 0.
    fn one(component_type: u64, components: usize) -> Layout {
        Layout {
            buffer: 0,
            offset: 0,
            stride: 16,
            count: 1,
            component_type,
            components,
        }
    }

    #[test]
    fn normalized_components_map_to_the_unit_range_as_the_spec_says() {
        let bytes = [255u8, 0, 128, 129];
        let l = one(UNSIGNED_BYTE, 4);
        let got: Vec<f64> = (0..4)
            .map(|c| read_number(&bytes, &l, 0, c, true))
            .collect();
        assert_eq!(got, [1.0, 0.0, 128.0 / 255.0, 129.0 / 255.0]);
        // signed: −128 and −127 both map to −1
        let l = one(BYTE, 4);
        let got: Vec<f64> = (0..4)
            .map(|c| read_number(&bytes, &l, 0, c, true))
            .collect();
        assert_eq!(got, [-1.0 / 127.0, 0.0, -1.0, -1.0]);
        let shorts: Vec<u8> = [65535u16, 0, 32768, 1]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let l = one(UNSIGNED_SHORT, 4);
        let got: Vec<f64> = (0..4)
            .map(|c| read_number(&shorts, &l, 0, c, true))
            .collect();
        assert_eq!(got, [1.0, 0.0, 32768.0 / 65535.0, 1.0 / 65535.0]);
        let l = one(SHORT, 4);
        let got: Vec<f64> = (0..4)
            .map(|c| read_number(&shorts, &l, 0, c, true))
            .collect();
        assert_eq!(got, [-1.0 / 32767.0, 0.0, -1.0, 1.0 / 32767.0]);
        // not normalized: the integers as read
        let got: Vec<f64> = (0..4)
            .map(|c| read_number(&shorts, &l, 0, c, false))
            .collect();
        assert_eq!(got, [-1.0, 0.0, -32768.0, 1.0]);
    }

    #[test]
    fn float_components_are_read_as_written_at_their_stride() {
        let bytes: Vec<u8> = [0.25f32, -1.5, 7.0, 0.1]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let l = Layout {
            stride: 8,
            count: 2,
            ..one(FLOAT, 2)
        };
        assert_eq!(read_number(&bytes, &l, 1, 0, false), 7.0);
        assert_eq!(read_number(&bytes, &l, 1, 1, true), f64::from(0.1f32));
        assert_eq!(read_number(&bytes, &l, 0, 1, false), -1.5);
    }

    /// Found by fuzzing (read_gltf_file, 6.2M runs in): a plain SHORT
    /// −32768 read could not be written back. Every stored integer of the
    /// small types, and the extremes of the large ones, read → encode →
    /// read gives the same number, normalized or not.
    #[test]
    fn encode_number_inverts_read_number_for_every_stored_value() {
        let stored = |t: u64, x: i64| -> Vec<u8> {
            match t {
                BYTE => (x as i8).to_le_bytes().to_vec(),
                UNSIGNED_BYTE => (x as u8).to_le_bytes().to_vec(),
                SHORT => (x as i16).to_le_bytes().to_vec(),
                UNSIGNED_SHORT => (x as u16).to_le_bytes().to_vec(),
                _ => (x as u32).to_le_bytes().to_vec(),
            }
        };
        let cases: [(u64, Vec<i64>); 5] = [
            (BYTE, (-128..=127).collect()),
            (UNSIGNED_BYTE, (0..=255).collect()),
            (SHORT, vec![-32768, -32767, -1, 0, 1, 32767]),
            (UNSIGNED_SHORT, vec![0, 1, 65534, 65535]),
            (UNSIGNED_INT, vec![0, 1, i64::from(u32::MAX)]),
        ];
        for (t, values) in cases {
            for x in values {
                for normalized in [false, true] {
                    let mut bytes = stored(t, x);
                    let v = read_number(&bytes, &one(t, 1), 0, 0, normalized);
                    let (b, size) = encode_number(t, normalized, v).unwrap();
                    bytes.copy_from_slice(&b[..size]);
                    let again = read_number(&bytes, &one(t, 1), 0, 0, normalized);
                    assert_eq!(again, v, "type {t} value {x} normalized {normalized}");
                }
            }
        }
        for (t, normalized, v) in [
            (SHORT, false, 0.5),
            (BYTE, true, 1.5),
            (UNSIGNED_BYTE, true, -0.1),
        ] {
            assert!(encode_number(t, normalized, v).is_err(), "{t} {v}");
        }
    }
}
