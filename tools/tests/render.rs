//! Pictures checked by looking, pixel for pixel: the tree's render equals a
//! brute-force render (same hit mask, same shaded values, so the same
//! shadows), and packets of 4 and 8 render exactly what single rays do.

use glam::Vec3;
use kdray_kernel::{PacketWidth, Triangle};
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::camera::{probe_tree, Camera, Placement};
use kdray_tools::demo_scene::teapot_in_stadium;
use kdray_tools::render::{
    render, render_heatmap, BruteTracer, Image, RenderParams, TreeTracer, BACKGROUND, LEGEND_HEIGHT,
};

/// A floor, and a tetrahedron floating above it that shadows it.
fn floor_and_tetrahedron() -> Vec<Triangle> {
    let f = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| Triangle { v: [a, b, c] };
    let (p, q, r, s) = (
        [-0.5, 0.6, -0.3],
        [0.5, 0.6, -0.3],
        [0.0, 0.6, 0.5],
        [0.0, 1.3, 0.0],
    );
    vec![
        f([-3.0, 0.0, -3.0], [3.0, 0.0, -3.0], [3.0, 0.0, 3.0]),
        f([-3.0, 0.0, -3.0], [3.0, 0.0, 3.0], [-3.0, 0.0, 3.0]),
        f(p, q, r),
        f(p, q, s),
        f(q, r, s),
        f(r, p, s),
    ]
}

/// Renders `tris` seen by `camera` with the tree at every packet width and
/// by brute force, and checks all four pictures are the same.
fn check_tree_matches_brute(tris: &[Triangle], camera: Camera, w: u32, h: u32) -> Image {
    check_tree_matches_brute_sampled(tris, camera, w, h, 1)
}

/// [`check_tree_matches_brute`] with `samples` rays a pixel.
fn check_tree_matches_brute_sampled(
    tris: &[Triangle],
    camera: Camera,
    w: u32,
    h: u32,
    samples: u32,
) -> Image {
    let built = build(tris, BuilderKind::default(), &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, tris).unwrap();
    let tree = blob.tree().unwrap();
    let params = RenderParams {
        samples,
        ..RenderParams::new(camera, w, h)
    };
    let brute = render(&BruteTracer(tris), &params, &|| ());
    assert_eq!((brute.width, brute.height), (w, h));
    for width in [
        PacketWidth::One,
        PacketWidth::Four,
        PacketWidth::Eight,
        PacketWidth::Sixteen,
    ] {
        let img = render(&TreeTracer { tree: &tree, width }, &params, &|| ());
        let silhouette =
            |i: &Image| -> Vec<bool> { i.pixels.iter().map(|&p| p != BACKGROUND).collect() };
        assert_eq!(silhouette(&img), silhouette(&brute), "{width:?}: hit mask");
        let diff = img
            .pixels
            .iter()
            .zip(&brute.pixels)
            .position(|(a, b)| a != b);
        assert_eq!(diff, None, "{width:?}: first differing pixel");
    }
    brute
}

#[test]
fn small_scene_tree_equals_brute_force_pixel_for_pixel() {
    let tris = floor_and_tetrahedron();
    let camera = Camera {
        eye: Vec3::new(0.3, 3.0, 4.0),
        target: Vec3::new(0.0, 0.3, 0.0),
        up: Vec3::Y,
        fov_deg: 45.0,
    };
    // Odd sizes: partial tiles at the right and bottom edges.
    let img = check_tree_matches_brute(&tris, camera, 61, 45);
    let distinct: std::collections::BTreeSet<_> = img.pixels.iter().collect();
    let background = img.pixels.iter().filter(|&&p| p == BACKGROUND).count();
    assert!(
        background > 0 && background < img.pixels.len() / 2,
        "{background}"
    );
    // Background, lit floor, shadowed floor, faces of the tetrahedron.
    assert!(distinct.len() >= 4, "{distinct:?}");
}

#[test]
fn built_in_scene_tree_equals_brute_force_pixel_for_pixel() {
    let scene = teapot_in_stadium();
    check_tree_matches_brute(&scene.triangles, Camera::framing(&scene.focus), 37, 27);
    check_tree_matches_brute_sampled(&scene.triangles, Camera::framing(&scene.focus), 19, 13, 4);
}

/// A UV sphere of radius 1 at the origin: `rings` x `sides` quads.
fn sphere(rings: usize, sides: usize) -> Vec<Triangle> {
    use std::f32::consts::{PI, TAU};
    let p = |r: usize, s: usize| {
        let th = r as f32 / rings as f32 * PI;
        let ph = (s % sides) as f32 / sides as f32 * TAU;
        [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]
    };
    let mut tris = Vec::new();
    for r in 0..rings {
        for s in 0..sides {
            let (a, b, c, d) = (p(r, s), p(r, s + 1), p(r + 1, s + 1), p(r + 1, s));
            tris.push(Triangle { v: [a, b, c] });
            tris.push(Triangle { v: [a, c, d] });
        }
    }
    tris
}

/// The camera looking at the unit sphere from +z.
fn sphere_camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.0, 4.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg: 35.0,
    }
}

#[test]
fn a_coarse_sphere_shades_smooth() {
    // 8 x 16 facets: flat shading gives each visible facet one colour,
    // lit or in shadow (113 colours); interpolated normals vary within
    // every facet (300).
    let tris = sphere(8, 16);
    let img = check_tree_matches_brute(&tris, sphere_camera(), 64, 64);
    let distinct: std::collections::BTreeSet<_> =
        img.pixels.iter().filter(|&&p| p != BACKGROUND).collect();
    assert!(distinct.len() > 200, "{} colours", distinct.len());
}

#[test]
fn supersampling_blends_edges_and_is_deterministic() {
    let tris = floor_and_tetrahedron();
    let camera = Camera {
        eye: Vec3::new(0.3, 3.0, 4.0),
        target: Vec3::new(0.0, 0.3, 0.0),
        up: Vec3::Y,
        fov_deg: 45.0,
    };
    let one = check_tree_matches_brute_sampled(&tris, camera, 45, 33, 1);
    let many = check_tree_matches_brute_sampled(&tris, camera, 45, 33, 16);
    assert_eq!(
        many,
        check_tree_matches_brute_sampled(&tris, camera, 45, 33, 16)
    );
    // Where the floor's edge meets the background, 16 samples mix the two:
    // colours that are neither, darker than the floor's and not the
    // background, where one sample a pixel has only the two.
    let background = |i: &Image| i.pixels.iter().filter(|&&p| p == BACKGROUND).count();
    let mixed = |i: &Image| {
        i.pixels
            .iter()
            .filter(|p| p.iter().zip(BACKGROUND).all(|(&c, b)| c.abs_diff(b) > 3) && p[0] < 120)
            .count()
    };
    assert!(background(&many) > 0 && background(&many) <= background(&one));
    assert!(
        mixed(&many) > mixed(&one) + 20,
        "{} {}",
        mixed(&many),
        mixed(&one)
    );
}

#[test]
fn heatmap_has_a_legend_and_costs_that_vary() {
    let scene = teapot_in_stadium();
    let built = build(
        &scene.triangles,
        BuilderKind::default(),
        &BuildParams::default(),
    )
    .unwrap();
    let blob = write_triangle_tree(&built, &scene.triangles).unwrap();
    let tree = blob.tree().unwrap();
    let params = RenderParams::new(Camera::framing(&scene.focus), 80, 60);
    let calls = std::sync::atomic::AtomicU32::new(0);
    let heat = render_heatmap(&tree, &params, &|| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    });
    assert_eq!(calls.into_inner(), 60, "one progress call per row");
    assert_eq!(
        (heat.image.width, heat.image.height),
        (80, 60 + LEGEND_HEIGHT)
    );
    assert!(
        heat.min < heat.max && f64::from(heat.min) < heat.mean,
        "{heat:?}"
    );
    // The legend's ramp runs dark to bright along its bar.
    let bar_row = 60 + 10;
    let lum = |x| {
        heat.image
            .get(x, bar_row)
            .unwrap()
            .iter()
            .map(|&c| u32::from(c))
            .sum::<u32>()
    };
    assert!(
        lum(8) < lum(40) && lum(40) < lum(70),
        "{} {} {}",
        lum(8),
        lum(40),
        lum(70)
    );
}

#[test]
fn png_round_trips() {
    let mut img = Image::filled(5, 3, [1, 2, 3]);
    img.set(4, 2, [200, 100, 50]);
    let path = std::env::temp_dir().join(format!("kdray-render-{}.png", std::process::id()));
    img.write_png(&path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (5, 3));
    assert_eq!(&buf[..3], &[1, 2, 3]);
    assert_eq!(
        &buf[info.buffer_size() - 3..info.buffer_size()],
        &[200, 100, 50]
    );
    let _ = std::fs::remove_file(path);
}

/// A closed box room, 20 x 6 x 8, wound so its normals point inwards (its
/// inside is the front), with a pillar (an outward-wound box) off its
/// centre: an interior scene. `inward` false turns the room inside out:
/// a closed object, its centre inside the solid.
fn room(inward: bool) -> Vec<Triangle> {
    let cube = |lo: [f32; 3], hi: [f32; 3], outward: bool| {
        let c = |i: usize| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        };
        // Each face's corners counter-clockwise seen from outside.
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        faces
            .iter()
            .flat_map(|f| {
                let [a, b, cc, d] = f.map(c);
                let tris = [Triangle { v: [a, b, cc] }, Triangle { v: [a, cc, d] }];
                tris.map(|t| {
                    if outward {
                        t
                    } else {
                        Triangle {
                            v: [t.v[0], t.v[2], t.v[1]],
                        }
                    }
                })
            })
            .collect::<Vec<_>>()
    };
    let mut tris = cube([-10.0, 0.0, -4.0], [10.0, 6.0, 4.0], !inward);
    tris.extend(cube([3.0, 0.0, 1.0], [4.0, 6.0, 2.0], true));
    tris
}

/// The fraction of a 40 x 30 picture's camera rays that hit `tree`.
fn hit_fraction(tree: &kdray_kernel::TriangleTree<'_>, camera: &Camera) -> f64 {
    let rays = camera.rays(40, 30);
    let hits = rays.iter().filter(|r| tree.closest_hit(r).is_hit()).count();
    hits as f64 / rays.len() as f64
}

#[test]
fn an_interior_is_framed_from_inside() {
    let tris = room(true);
    let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, &tris).unwrap();
    let tree = blob.tree().unwrap();
    let bounds = tree.bounds();
    let probe = |r: &kdray_kernel::Ray| probe_tree(&tree, r);
    assert!(Camera::encloses(&bounds, probe));
    let auto = Camera::placed(&bounds, Placement::Auto, probe);
    assert_eq!(auto, Camera::placed(&bounds, Placement::Inside, probe));
    assert_eq!(auto, Camera::inside(&bounds, probe));
    let inside = |p: Vec3| (0..3).all(|a| p[a] > bounds.min[a] && p[a] < bounds.max[a]);
    assert!(inside(auto.eye) && inside(auto.target), "{auto:?}");
    // Along the long side (x), at the wall with more room (the pillar
    // stands at x = 3..4 but off the line through the centre).
    assert_eq!(auto.eye.y, 3.0);
    assert!(
        (auto.target - auto.eye)
            .normalize()
            .abs_diff_eq(Vec3::NEG_X, 1e-6)
            || (auto.target - auto.eye)
                .normalize()
                .abs_diff_eq(Vec3::X, 1e-6),
        "{auto:?}"
    );
    // From outside, the closed room is a box seen from a distance; from
    // inside, every ray meets a wall.
    let outside = Camera::placed(&bounds, Placement::Outside, probe);
    assert_eq!(outside, Camera::framing(&bounds));
    let (before, after) = (hit_fraction(&tree, &outside), hit_fraction(&tree, &auto));
    assert!(before < 0.6 && after == 1.0, "{before} {after}");
    // The light lands inside the room too: lit floor, not all in shadow.
    let params = RenderParams::new(auto, 40, 30);
    assert!(inside(params.light), "{:?}", params.light);
}

#[test]
fn a_closed_object_is_framed_from_outside() {
    let tris = room(false);
    let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, &tris).unwrap();
    let tree = blob.tree().unwrap();
    let bounds = tree.bounds();
    let probe = |r: &kdray_kernel::Ray| probe_tree(&tree, r);
    assert!(!Camera::encloses(&bounds, probe));
    assert_eq!(
        Camera::placed(&bounds, Placement::Auto, probe),
        Camera::framing(&bounds)
    );
}
