//! The containers around a glTF document (glTF 2.0 §4.4 "GLB File Format
//! Specification"): the 12-byte GLB header, its JSON chunk, its BIN chunk
//! and any further chunks; buffers in `data:` URIs (base64) or in files next
//! to the `.gltf`, named by (percent-encoded) relative URIs.

use super::base64;
use std::path::{Path, PathBuf};

/// `glTF` read as a little-endian u32: the first 4 bytes of a GLB file.
pub(crate) const GLB_MAGIC: u32 = 0x4654_6C67;
/// Chunk type of the JSON chunk (`JSON`).
pub(crate) const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type of the binary buffer chunk (`BIN\0`).
pub(crate) const CHUNK_BIN: u32 = 0x004E_4942;

/// A GLB file taken apart.
pub(crate) struct Glb<'a> {
    /// the JSON chunk's bytes (padding spaces included)
    pub json: &'a [u8],
    /// the BIN chunk's bytes (padding included), if the file has one
    pub bin: Option<&'a [u8]>,
    /// further chunks (type, bytes), in file order
    pub other: Vec<(u32, Vec<u8>)>,
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Takes a GLB file apart; `Err` names the byte offset and what is wrong.
pub(crate) fn split_glb(bytes: &[u8]) -> Result<Glb<'_>, String> {
    if bytes.len() < 12 {
        return Err(format!(
            "truncated GLB: {} bytes, the header alone has 12",
            bytes.len()
        ));
    }
    if u32_at(bytes, 0) != GLB_MAGIC {
        return Err("no GLB file: it does not start with \"glTF\"".into());
    }
    let version = u32_at(bytes, 4);
    if version != 2 {
        return Err(format!("GLB version {version}, only version 2 is read"));
    }
    let length = u32_at(bytes, 8) as usize;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: the header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    if length < 12 {
        return Err(format!(
            "GLB header says the file has {length} bytes, fewer than its header"
        ));
    }
    let bytes = &bytes[..length];
    let mut at = 12;
    let mut chunks: Vec<(usize, u32, &[u8])> = Vec::new();
    while at < length {
        if length - at < 8 {
            return Err(format!(
                "truncated GLB chunk at byte {at}: {} bytes left, a chunk header has 8",
                length - at
            ));
        }
        let chunk_length = u32_at(bytes, at) as usize;
        let chunk_type = u32_at(bytes, at + 4);
        let start = at + 8;
        if chunk_length > length - start {
            return Err(format!(
                "GLB chunk {} at byte {at} ({}) has {chunk_length} bytes, the file ends {} \
                 bytes after its header",
                chunks.len(),
                chunk_name(chunk_type),
                length - start
            ));
        }
        chunks.push((at, chunk_type, &bytes[start..start + chunk_length]));
        at = start + chunk_length;
    }
    let Some(&(_, first_type, json)) = chunks.first() else {
        return Err("GLB file without chunks: the JSON chunk is missing".into());
    };
    if first_type != CHUNK_JSON {
        return Err(format!(
            "GLB chunk 0 at byte 12 is {}, the first chunk must be JSON",
            chunk_name(first_type)
        ));
    }
    let mut bin = None;
    let mut other = Vec::new();
    for (i, &(offset, chunk_type, data)) in chunks.iter().enumerate().skip(1) {
        match chunk_type {
            CHUNK_BIN if i == 1 => bin = Some(data),
            CHUNK_JSON | CHUNK_BIN => {
                return Err(format!(
                    "GLB chunk {i} at byte {offset} is a second {} chunk",
                    chunk_name(chunk_type)
                ));
            }
            _ => other.push((chunk_type, data.to_vec())),
        }
    }
    Ok(Glb { json, bin, other })
}

/// A chunk type for messages: `JSON`, `BIN`, or its hexadecimal value.
fn chunk_name(chunk_type: u32) -> String {
    match chunk_type {
        CHUNK_JSON => "JSON".into(),
        CHUNK_BIN => "BIN".into(),
        t => format!("of unknown type 0x{t:08x}"),
    }
}

/// Assembles a GLB file: the JSON padded with spaces and the chunks with
/// zeros to multiples of 4 bytes, as the specification requires.
pub(crate) fn join_glb(json: &[u8], bin: Option<&[u8]>, other: &[(u32, Vec<u8>)]) -> Vec<u8> {
    let padded = |n: usize| n.div_ceil(4) * 4;
    let mut chunks: Vec<(u32, &[u8], u8)> = vec![(CHUNK_JSON, json, b' ')];
    if let Some(bin) = bin {
        chunks.push((CHUNK_BIN, bin, 0));
    }
    chunks.extend(other.iter().map(|(t, d)| (*t, d.as_slice(), 0)));
    let total: usize = 12
        + chunks
            .iter()
            .map(|(_, d, _)| 8 + padded(d.len()))
            .sum::<usize>();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&GLB_MAGIC.to_le_bytes());
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    for (chunk_type, data, pad) in chunks {
        out.extend_from_slice(&(padded(data.len()) as u32).to_le_bytes());
        out.extend_from_slice(&chunk_type.to_le_bytes());
        out.extend_from_slice(data);
        out.resize(out.len() + padded(data.len()) - data.len(), pad);
    }
    out
}

/// What a `uri` of a buffer or image names.
#[derive(Debug, PartialEq)]
pub(crate) enum Uri<'a> {
    /// a `data:` URI: what precedes its base64 text (`data:…;base64,`) and
    /// that text
    Data { prefix: &'a str, base64: &'a str },
    /// a relative reference: the file it names, percent-decoded, relative
    /// to the document's folder
    File(PathBuf),
    /// anything else (`http:`, `file:`, a `data:` URI that is not base64)
    Other,
}

/// Classifies a `uri`.
pub(crate) fn classify(uri: &str) -> Uri<'_> {
    if let Some(rest) = uri.strip_prefix("data:") {
        return match rest.find(";base64,") {
            Some(i) => {
                let split = "data:".len() + i + ";base64,".len();
                Uri::Data {
                    prefix: &uri[..split],
                    base64: &uri[split..],
                }
            }
            None => Uri::Other,
        };
    }
    // a scheme is letters, digits, + - . before the first ':' (RFC 3986 §3.1)
    if let Some(colon) = uri.find(':') {
        let scheme = &uri[..colon];
        let is_scheme = scheme.len() > 1
            && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
            && scheme
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
        if is_scheme {
            return Uri::Other;
        }
    }
    match percent_decode(uri) {
        Some(path) => Uri::File(PathBuf::from(path)),
        None => Uri::Other,
    }
}

/// `%XX` escapes decoded; `None` for a bad escape or a result that is no
/// UTF-8 text.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// A relative path as a URI reference: `/`-separated, every byte outside
/// RFC 3986's unreserved characters (and `/`) percent-encoded.
pub(crate) fn path_to_uri(path: &Path) -> String {
    let parts: Vec<String> = path
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let mut out = String::new();
    for (i, part) in parts.iter().enumerate() {
        if i > 0 {
            out.push('/');
        }
        for &b in part.as_bytes() {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                out.push(b as char);
            } else {
                out.push_str(&format!("%{b:02X}"));
            }
        }
    }
    out
}

/// Decodes a `data:` URI's base64 text.
pub(crate) fn decode_data(base64_text: &str) -> Result<Vec<u8>, String> {
    base64::decode(base64_text.as_bytes())
}

/// A `data:` URI of `bytes` with the given prefix (`data:…;base64,`).
pub(crate) fn encode_data(prefix: &str, bytes: &[u8]) -> String {
    format!("{prefix}{}", base64::encode(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_join_then_split_gives_the_chunks_back_padded() {
        let other = vec![(0x1234_5678, vec![9u8; 5])];
        let glb = join_glb(b"{}", Some(&[1, 2, 3]), &other);
        assert_eq!(glb.len() % 4, 0);
        let parts = split_glb(&glb).unwrap();
        assert_eq!(parts.json, b"{}  ");
        assert_eq!(parts.bin, Some(&[1u8, 2, 3, 0][..]));
        assert_eq!(
            parts.other,
            vec![(0x1234_5678, vec![9, 9, 9, 9, 9, 0, 0, 0])]
        );
    }

    #[test]
    fn broken_glb_files_name_the_byte() {
        let glb = join_glb(b"{}", Some(&[1, 2, 3, 4]), &[]);
        let e = split_glb(&glb[..glb.len() - 2]).err().unwrap();
        assert!(
            e.contains("truncated GLB: the header says 36 bytes, the file has 34"),
            "{e}"
        );
        let mut cut = glb.clone();
        cut[24..28].copy_from_slice(&100u32.to_le_bytes());
        let e = split_glb(&cut).err().unwrap();
        assert!(e.contains("chunk 1 at byte 24 (BIN) has 100 bytes"), "{e}");
        let mut wrong = glb.clone();
        wrong[16..20].copy_from_slice(&CHUNK_BIN.to_le_bytes());
        let e = split_glb(&wrong).err().unwrap();
        assert!(e.contains("chunk 0 at byte 12 is BIN"), "{e}");
        assert!(split_glb(b"glTF").err().unwrap().contains("12"));
    }

    #[test]
    fn uris_are_classified_and_percent_coded() {
        assert_eq!(
            classify("data:application/octet-stream;base64,AAAA"),
            Uri::Data {
                prefix: "data:application/octet-stream;base64,",
                base64: "AAAA"
            }
        );
        assert_eq!(
            classify("tex%20a.png"),
            Uri::File(PathBuf::from("tex a.png"))
        );
        assert_eq!(
            classify("../a/b.bin"),
            Uri::File(PathBuf::from("../a/b.bin"))
        );
        assert_eq!(classify("https://x/y.bin"), Uri::Other);
        assert_eq!(classify("data:text/plain,abc"), Uri::Other);
        assert_eq!(classify("bad%zz"), Uri::Other);
        assert_eq!(
            path_to_uri(Path::new("../in/tex a.png")),
            "../in/tex%20a.png"
        );
    }
}
