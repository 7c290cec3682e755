//! Pictures of a tree: shaded renders (a pinhole camera, smooth shading
//! normals (`normals.rs`), one point light with an exact shadow ray, and
//! `samples` rays a pixel in a fixed sub-pixel pattern) and
//! traversal-cost heatmaps, traced on all threads of the current rayon
//! pool, in tiles that match the packet width so each tile (at one
//! sub-pixel offset) is one packet.

mod font;
mod heatmap;
mod image;
mod normals;
mod tracer;

pub use heatmap::{render_heatmap, Heatmap, LEGEND_HEIGHT};
pub use image::Image;
pub use normals::CREASE_DEG;
pub use tracer::{BruteTracer, Tracer, TreeTracer};

use normals::ShadingNormals;

use crate::camera::Camera;
use glam::Vec3;
use kdray_kernel::{Hit, PacketWidth, Ray, SurfacePoint, Triangle};
use rayon::prelude::*;

/// What to render and from where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderParams {
    /// The camera.
    pub camera: Camera,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The point light.
    pub light: Vec3,
    /// Rays a pixel (1 to [`MAX_SAMPLES`]), at the offsets of
    /// [`sample_offsets`], their colours averaged in linear light.
    pub samples: u32,
}

/// The most rays a pixel [`RenderParams::samples`] may ask for.
pub const MAX_SAMPLES: u32 = 64;

/// Where in a pixel its `n` rays go, as `(x, y)` in `[0, 1)` from its
/// top left corner: a Hammersley set, `x = (k + 1/2) / n` and `y` the
/// bit-reversed `k` shifted by `1 / 2n` (so one sample is the centre, and
/// four form a rotated grid). Fixed: the same picture on every run.
#[must_use]
pub fn sample_offsets(n: u32) -> Vec<[f32; 2]> {
    let n = n.max(1);
    (0..n)
        .map(|k| {
            let reversed = f64::from(k.reverse_bits()) / 4_294_967_296.0;
            let y = (reversed + 0.5 / f64::from(n)).fract();
            [((f64::from(k) + 0.5) / f64::from(n)) as f32, y as f32]
        })
        .collect()
}

impl RenderParams {
    /// `camera` at `width` x `height`, with the light above and to the
    /// left of the eye. Shadow rays need no scene-sized offset: they start
    /// past the hit point's own error bound ([`SurfacePoint`]).
    #[must_use]
    pub fn new(camera: Camera, width: u32, height: u32) -> RenderParams {
        let fwd = (camera.target - camera.eye).normalize_or(Vec3::NEG_Z);
        let right = fwd.cross(camera.up).normalize_or(Vec3::X);
        let dist = (camera.target - camera.eye).length();
        RenderParams {
            camera,
            width,
            height,
            light: camera.eye + (camera.up * 0.9 - right * 0.6) * dist,
            samples: 1,
        }
    }
}

/// The colour of a ray that hits nothing.
pub const BACKGROUND: [u8; 3] = [28, 32, 44];
/// Light every surface gets, lit or not.
const AMBIENT: f32 = 0.12;
/// The part of the light that only follows the view (so shapes in shadow
/// still read); the rest comes from the point light, by the cosine of
/// the shading normal with the way to it, where the shadow ray is clear.
const IN_SHADOW: f32 = 0.35;
/// The surface colour (linear RGB).
const ALBEDO: [f32; 3] = [0.95, 0.82, 0.62];

/// Tile width and height in pixels for a packet width: 4x4 for 16
/// lanes, 4x2 for 8, 2x2 for 4, single pixels for 1.
#[must_use]
pub const fn tile_size(width: PacketWidth) -> (u32, u32) {
    match width {
        PacketWidth::One => (1, 1),
        PacketWidth::Four => (2, 2),
        PacketWidth::Eight => (4, 2),
        PacketWidth::Sixteen => (4, 4),
    }
}

/// A shaded picture of what `tracer` sees; `progress` is called once per
/// finished band of tile rows (`bands(...)` of them).
pub fn render(tracer: &impl Tracer, params: &RenderParams, progress: &(dyn Fn() + Sync)) -> Image {
    let tile = tile_size(tracer.packet_width());
    let shading = Shading {
        normals: ShadingNormals::new(tracer.triangles()),
        offsets: sample_offsets(params.samples.clamp(1, MAX_SAMPLES)),
        background: BACKGROUND.map(|c| (f32::from(c) / 255.0).powf(2.2)),
    };
    let pixels = in_tiles(
        params.width,
        params.height,
        tile,
        progress,
        |coords, out| {
            shade_tile(tracer, params, &shading, coords, out);
        },
    );
    Image {
        width: params.width,
        height: params.height,
        pixels,
    }
}

/// How many times `render` calls `progress` for this tracer's tiles.
#[must_use]
pub fn bands(height: u32, width: PacketWidth) -> u64 {
    u64::from(height.div_ceil(tile_size(width).1))
}

/// What every tile's shading shares: the mesh's shading normals, the
/// sub-pixel offsets, and the background in linear light.
struct Shading {
    normals: ShadingNormals,
    offsets: Vec<[f32; 2]>,
    background: [f32; 3],
}

/// One tile: its camera rays, sub-pixel offset by offset (so each
/// offset's rays are one packet), then the shadow rays of the surfaces
/// facing the light; each pixel the mean of its samples in linear light
/// (a pixel no ray hit is exactly the background).
fn shade_tile(
    tracer: &impl Tracer,
    p: &RenderParams,
    shading: &Shading,
    coords: &[[u32; 2]],
    out: &mut [[u8; 3]],
) {
    let rays: Vec<Ray> = shading
        .offsets
        .iter()
        .flat_map(|&[ox, oy]| {
            coords.iter().map(move |&[x, y]| {
                p.camera
                    .ray_at(x as f32 + ox, y as f32 + oy, p.width, p.height)
            })
        })
        .collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    tracer.closest(&rays, &mut hits);
    let surfaces: Vec<Option<Surface>> = rays
        .iter()
        .zip(&hits)
        .map(|(r, h)| Surface::at(tracer.triangles(), Some(&shading.normals), r, h, p))
        .collect();
    let shadow_rays: Vec<Ray> = surfaces.iter().flatten().filter_map(|s| s.shadow).collect();
    let mut occluded = vec![false; shadow_rays.len()];
    tracer.occluded(&shadow_rays, &mut occluded);
    let mut shadows = occluded.into_iter();
    let linear: Vec<Option<[f32; 3]>> = surfaces
        .iter()
        .map(|s| {
            let s = s.as_ref()?;
            let lit = s.shadow.is_some() && shadows.next() == Some(false);
            let direct = IN_SHADOW + (1.0 - IN_SHADOW) * if lit { s.diffuse } else { 0.0 };
            Some(shade(AMBIENT + (1.0 - AMBIENT) * s.facing * direct))
        })
        .collect();
    let n = coords.len();
    for (i, o) in out.iter_mut().enumerate() {
        let samples = linear.iter().skip(i).step_by(n);
        *o = if samples.clone().all(Option::is_none) {
            BACKGROUND
        } else {
            let sum = samples.fold([0.0f32; 3], |sum, c| {
                let c = c.unwrap_or(shading.background);
                std::array::from_fn(|k| sum[k] + c[k])
            });
            to_srgb(sum.map(|c| c / shading.offsets.len() as f32))
        };
    }
}

/// Appends the pixels of the `tw` x `rows` tile whose top left is `[x0,
/// y0]`, row by row, cut at the image's right edge `width`.
fn tile_pixels(width: u32, [x0, y0]: [u32; 2], (tw, rows): (u32, u32), out: &mut Vec<[u32; 2]>) {
    for y in y0..y0 + rows {
        out.extend((x0..(x0 + tw).min(width)).map(|x| [x, y]));
    }
}

/// Every pixel of a `width` x `height` image in the order the renderer
/// traces them: tile by tile (`tile` pixels, smaller at the right and
/// bottom edges), left to right, bands of tile rows top to bottom, each
/// tile row by row. A ray file in this order traces as one packet per tile.
#[must_use]
pub fn tiled_pixels(width: u32, height: u32, tile: (u32, u32)) -> Vec<[u32; 2]> {
    let mut out = Vec::with_capacity(width as usize * height as usize);
    tiled_pixels_into(width, height, tile, &mut out);
    out
}

/// [`tiled_pixels`] appended to `out` (for a caller that reserves their
/// room itself).
pub fn tiled_pixels_into(width: u32, height: u32, (tw, th): (u32, u32), out: &mut Vec<[u32; 2]>) {
    for y0 in (0..height).step_by(th.max(1) as usize) {
        let rows = th.min(height - y0);
        for x0 in (0..width).step_by(tw.max(1) as usize) {
            tile_pixels(width, [x0, y0], (tw, rows), out);
        }
    }
}

/// The shadow ray `render` traces from where `ray` hit (`hit`, a triangle
/// of `tris`) to the light of `params`, or `None` for a miss or a surface
/// facing away from the light.
#[must_use]
pub fn shadow_ray(tris: &[Triangle], ray: &Ray, hit: &Hit, params: &RenderParams) -> Option<Ray> {
    Surface::at(tris, None, ray, hit, params)?.shadow
}

/// A visible surface point.
struct Surface {
    /// The cosine of the angle between the shading normal (on the
    /// viewer's side) and the way back to the eye, at least 0.
    facing: f32,
    /// The ray to the light, when the light is on the viewer's side of
    /// the triangle's plane.
    shadow: Option<Ray>,
    /// The cosine of the angle between the shading normal and the way to
    /// the light, at least 0: near the line where the facets turn from
    /// the light it is near 0 on both sides, so that line does not show
    /// the facets' steps.
    diffuse: f32,
}

impl Surface {
    /// The surface `ray` hit: shaded with `normals` when given, else the
    /// triangle's geometric normal. Whether it faces the light, and its
    /// shadow ray, depend on the triangle's plane alone: the shadow ray
    /// starts at the exact hit point and is traced exactly.
    fn at(
        tris: &[Triangle],
        normals: Option<&ShadingNormals>,
        ray: &Ray,
        hit: &Hit,
        p: &RenderParams,
    ) -> Option<Surface> {
        let tri = tris.get(hit.prim as usize)?;
        let [a, b, c] = tri.v.map(Vec3::from);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let view = Vec3::from(ray.dir).normalize_or_zero();
        // The normal on the viewer's side of the triangle.
        let n = if n.dot(view) > 0.0 { -n } else { n };
        let surface = SurfacePoint::new(tri, hit);
        let to_light = p.light - Vec3::from(surface.p);
        let shadow = (n.dot(to_light) > 0.0).then(|| surface.spawn_to(p.light.to_array()));
        // The shading normal, turned to the same side.
        let s = normals.and_then(|s| s.at(hit)).unwrap_or(n);
        let s = if s.dot(n) < 0.0 { -s } else { s };
        Some(Surface {
            facing: (-s.dot(view)).max(0.0),
            shadow,
            diffuse: s.dot(to_light.normalize_or_zero()).max(0.0),
        })
    }
}

/// Linear intensity to the albedo's colour in linear light.
fn shade(intensity: f32) -> [f32; 3] {
    ALBEDO.map(|a| (a * intensity).clamp(0.0, 1.0))
}

/// A colour in linear light to 8-bit sRGB (gamma 2.2).
fn to_srgb(linear: [f32; 3]) -> [u8; 3] {
    linear.map(|c| (c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0 + 0.5) as u8)
}

/// Runs `per_tile` on every tile of a `width` x `height` image (tiles of
/// `tile` pixels, smaller at the right and bottom edges), one band of tile
/// rows per parallel task, and gathers the values row by row.
/// `per_tile` gets the tile's pixel coordinates, row by row within the
/// tile, and fills one value per pixel.
fn in_tiles<T: Copy + Default + Send>(
    width: u32,
    height: u32,
    (tw, th): (u32, u32),
    progress: &(dyn Fn() + Sync),
    per_tile: impl Fn(&[[u32; 2]], &mut [T]) + Sync,
) -> Vec<T> {
    let w = width as usize;
    let mut out = vec![T::default(); w * height as usize];
    if w == 0 {
        return out;
    }
    out.par_chunks_mut(w * th as usize)
        .enumerate()
        .for_each(|(band, rows)| {
            let y0 = band as u32 * th;
            let rows_here = (rows.len() / w) as u32;
            let mut coords = Vec::with_capacity((tw * th) as usize);
            let mut values = vec![T::default(); (tw * th) as usize];
            for x0 in (0..width).step_by(tw as usize) {
                coords.clear();
                tile_pixels(width, [x0, y0], (tw, rows_here), &mut coords);
                let values = &mut values[..coords.len()];
                per_tile(&coords, values);
                for (&[x, y], &v) in coords.iter().zip(values.iter()) {
                    rows[(y - y0) as usize * w + x as usize] = v;
                }
            }
            progress();
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_offsets_are_a_fixed_stratified_set() {
        assert_eq!(sample_offsets(1), vec![[0.5, 0.5]]);
        assert_eq!(
            sample_offsets(4),
            vec![
                [0.125, 0.125],
                [0.375, 0.625],
                [0.625, 0.375],
                [0.875, 0.875]
            ]
        );
        for n in [2, 3, 16, 64] {
            let s = sample_offsets(n);
            assert_eq!(s.len(), n as usize);
            assert!(
                s.iter().flatten().all(|&c| (0.0..1.0).contains(&c)),
                "{s:?}"
            );
            // One sample in each of n columns and each of n rows.
            for axis in 0..2 {
                let mut cells: Vec<u32> = s.iter().map(|p| (p[axis] * n as f32) as u32).collect();
                cells.sort_unstable();
                cells.dedup();
                assert_eq!(cells.len(), n as usize, "{n} {axis}: {s:?}");
            }
        }
    }
}
