//! Smoke test: a random soup traced through a written blob equals brute force.
use kdray::kernel::{closest_hit_brute, Ray, Triangle};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::build::{build, BuildParams, BuilderKind};

fn lcg(s: &mut u64) -> f32 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*s >> 40) as f32) / (1u64 << 24) as f32
}

#[test]
fn random_soup_matches_brute() {
    let mut s = 1;
    let tris: Vec<Triangle> = (0..2000)
        .map(|_| {
            let c = [lcg(&mut s) * 10.0, lcg(&mut s) * 10.0, lcg(&mut s) * 10.0];
            Triangle {
                v: std::array::from_fn(|_| std::array::from_fn(|a| c[a] + lcg(&mut s) - 0.5)),
            }
        })
        .collect();
    let built = build(&tris, BuilderKind::Sah, &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, &tris);
    let tree = blob.tree().unwrap();
    let mut hits = 0;
    for _ in 0..20000 {
        let o = [
            lcg(&mut s) * 12.0 - 1.0,
            lcg(&mut s) * 12.0 - 1.0,
            lcg(&mut s) * 12.0 - 1.0,
        ];
        let d = [lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5];
        let r = Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        };
        let a = tree.closest_hit(&r);
        let b = closest_hit_brute(&tris, &r);
        assert_eq!(a.bits(), b.bits(), "{r:?}");
        hits += a.is_hit() as u32;
    }
    println!("nodes {} hits {hits}", tree.nodes().len());
    assert!(hits > 1000);
}
