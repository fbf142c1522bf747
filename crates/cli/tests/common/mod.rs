//! Helpers shared by the CLI's integration tests (`mod common;`).
#![allow(dead_code)] // each test binary uses a part of them

use normalnet_mesh::Mesh;
use std::path::Path;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

/// `normalnet ARGS…` with the built-in model (`NORMALNET_MODEL` unset).
pub fn normalnet(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .env_remove("NORMALNET_MODEL")
        .args(args)
        .output()
        .expect("normalnet runs")
}

/// A path as the `&str` an argument list takes.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// What a run printed on stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A UV sphere, `rings` × `segs`, whose ring vertex `(i, j)` lies at radius
/// `1 + bump·((7i + 13j) mod 5)` (poles at 1).
pub fn bumpy_sphere(rings: usize, segs: usize, bump: f64) -> Mesh {
    let mut m = Mesh::uv_sphere(rings, segs);
    let ring_vertices = (rings - 1) * segs;
    for (k, p) in m
        .positions
        .iter_mut()
        .enumerate()
        .skip(1)
        .take(ring_vertices)
    {
        let (i, j) = (1 + (k - 1) / segs, (k - 1) % segs);
        let r = 1.0 + bump * ((7 * i + 13 * j) % 5) as f64;
        *p = p.map(|c| c * r);
    }
    m
}

/// A slightly bumpy sphere (big enough for a slow denoise at 60 × 120).
pub fn sphere(rings: usize, segs: usize) -> Mesh {
    bumpy_sphere(rings, segs, 0.02)
}

/// A GNF denoise of a 60 × 120 sphere written into `dir` with 100,000
/// iterations (minutes: long enough to be interrupted), stderr piped; the
/// child and the output path it would write.
pub fn spawn_long_denoise(dir: &Path) -> (Child, PathBuf) {
    let input = dir.join("in.obj");
    normalnet_mesh::write_mesh(&input, &sphere(60, 120)).unwrap();
    let out = dir.join("out.obj");
    let child = Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .args(["denoise", "-q", "-m", "gnf", "--iterations", "100000"])
        .arg(&input)
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    (child, out)
}

/// Sends SIGINT to `child` and waits up to 30 s for it to exit; panics
/// (after killing it) with "normalnet did not stop on SIGINT{what}" if it
/// does not.
pub fn interrupt_and_wait(child: &mut Child, what: &str) -> ExitStatus {
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let start = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("normalnet did not stop on SIGINT{what}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}
