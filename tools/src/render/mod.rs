//! Pictures of a tree: shaded renders (a pinhole camera, the hit
//! triangle's geometric normal, one point light with a shadow ray) and
//! traversal-cost heatmaps, traced on all threads of the current rayon
//! pool, in tiles that match the packet width so each tile is one packet.

mod font;
mod heatmap;
mod image;
mod tracer;

pub use heatmap::{render_heatmap, Heatmap, LEGEND_HEIGHT};
pub use image::Image;
pub use tracer::{BruteTracer, Tracer, TreeTracer};

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
        }
    }
}

/// The colour of a ray that hits nothing.
pub const BACKGROUND: [u8; 3] = [28, 32, 44];
/// Light every surface gets, lit or not.
const AMBIENT: f32 = 0.12;
/// The fraction of direct light a shadowed surface keeps (so shapes in
/// shadow still read).
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
    let pixels = in_tiles(
        params.width,
        params.height,
        tile,
        progress,
        |coords, out| {
            shade_tile(tracer, params, coords, out);
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

/// One tile: camera rays as one packet, then shadow rays of the surfaces
/// facing the light as another.
fn shade_tile(tracer: &impl Tracer, p: &RenderParams, coords: &[[u32; 2]], out: &mut [[u8; 3]]) {
    let rays: Vec<Ray> = coords
        .iter()
        .map(|&[x, y]| p.camera.ray(x, y, p.width, p.height))
        .collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    tracer.closest(&rays, &mut hits);
    let surfaces: Vec<Option<Surface>> = rays
        .iter()
        .zip(&hits)
        .map(|(r, h)| Surface::at(tracer.triangles(), r, h, p))
        .collect();
    let shadow_rays: Vec<Ray> = surfaces.iter().flatten().filter_map(|s| s.shadow).collect();
    let mut occluded = vec![false; shadow_rays.len()];
    tracer.occluded(&shadow_rays, &mut occluded);
    let mut shadows = occluded.into_iter();
    for (o, s) in out.iter_mut().zip(&surfaces) {
        *o = match s {
            None => BACKGROUND,
            Some(s) => {
                let lit = s.shadow.is_some() && shadows.next() == Some(false);
                let direct = if lit { 1.0 } else { IN_SHADOW };
                to_srgb(AMBIENT + (1.0 - AMBIENT) * s.facing * direct)
            }
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
    Surface::at(tris, ray, hit, params)?.shadow
}

/// A visible surface point.
struct Surface {
    /// `|cos|` of the angle between the geometric normal and the view ray.
    facing: f32,
    /// The ray to the light, when the light is on the viewer's side.
    shadow: Option<Ray>,
}

impl Surface {
    fn at(tris: &[Triangle], ray: &Ray, hit: &Hit, p: &RenderParams) -> Option<Surface> {
        let tri = tris.get(hit.prim as usize)?;
        let [a, b, c] = tri.v.map(Vec3::from);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let view = Vec3::from(ray.dir).normalize_or_zero();
        let cos = n.dot(view);
        // The normal on the viewer's side of the triangle.
        let n = if cos > 0.0 { -n } else { n };
        let surface = SurfacePoint::new(tri, hit);
        let to_light = p.light - Vec3::from(surface.p);
        let shadow = (n.dot(to_light) > 0.0).then(|| surface.spawn_to(p.light.to_array()));
        Some(Surface {
            facing: cos.abs(),
            shadow,
        })
    }
}

/// Linear intensity to the albedo's 8-bit sRGB colour.
fn to_srgb(intensity: f32) -> [u8; 3] {
    ALBEDO.map(|a| {
        let linear = (a * intensity).clamp(0.0, 1.0);
        (linear.powf(1.0 / 2.2) * 255.0 + 0.5) as u8
    })
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
