//! Helpers shared by the CLI's integration tests (`mod common;`).

use normalnet_mesh::Mesh;
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// A UV sphere, `rings` × `segs`, slightly bumpy (big enough for a slow
/// denoise at 60 × 120).
pub fn sphere(rings: usize, segs: usize) -> Mesh {
    let mut p = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segs {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / segs as f64;
            let r = 1.0 + 0.02 * ((7 * i + 13 * j) % 5) as f64;
            p.push([
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ]);
        }
    }
    p.push([0.0, 0.0, -1.0]);
    let last = (p.len() - 1) as u32;
    let id = |i: usize, j: usize| (1 + (i - 1) * segs + j % segs) as u32;
    let mut f = Vec::new();
    for j in 0..segs {
        f.push([0, id(1, j), id(1, j + 1)]);
        f.push([last, id(rings - 1, j + 1), id(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segs {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::new(p, f).unwrap()
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
