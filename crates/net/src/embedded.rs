//! The shipped `models/lite` bundle compiled into the library (feature
//! `embedded-model`): a program finds its default model wherever it is
//! installed, without the source tree.

use crate::NetError;
use crate::bundle::Bundle;

/// What the embedded bundle is called in messages and `--json` output.
pub const EMBEDDED_LABEL: &str = "<built-in models/lite>";

macro_rules! lite_file {
    ($name:literal) => {
        include_bytes!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/lite/",
            $name
        ))
    };
}

static MANIFEST: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../models/lite/manifest.toml"
));

static NETWORKS: [&[u8]; 6] = [
    lite_file!("net1.safetensors"),
    lite_file!("net2.safetensors"),
    lite_file!("net3.safetensors"),
    lite_file!("net4.safetensors"),
    lite_file!("net5.safetensors"),
    lite_file!("net6.safetensors"),
];

/// The shipped lite bundle, parsed and compiled (a few milliseconds).
pub fn lite() -> Result<Bundle, NetError> {
    Bundle::from_bytes(EMBEDDED_LABEL, MANIFEST, &NETWORKS)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_embedded_bundle_is_the_shipped_folder() {
        let embedded = super::lite().unwrap();
        let folder = crate::Bundle::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/lite"));
        let folder = folder.unwrap();
        assert_eq!(embedded.manifest, folder.manifest);
        assert_eq!(embedded.networks, folder.networks);
    }
}
