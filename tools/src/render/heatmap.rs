//! Traversal-cost heatmaps: per pixel, the nodes visited (interior and
//! leaf) plus the ray/triangle tests of the closest-hit search of the
//! camera ray through the pixel's centre, on a logarithmic colour ramp (a
//! few silhouette rays cost tens of times the median; a linear ramp would
//! paint everything else black), with a legend strip below the picture:
//! the ramp labelled with the smallest, middle and largest cost, and a
//! caption saying the scale is logarithmic and what is counted. The
//! strip adds [`LEGEND_HEIGHT`] rows: the picture above it is the size
//! asked, its rays the same as a shaded picture's.

use super::font::{draw_text, text_width, HEIGHT as FONT_HEIGHT};
use super::{in_tiles, Image, RenderParams, BACKGROUND};
use kdray_kernel::TriangleTree;

/// Height in pixels of the legend strip under a heatmap: the image is
/// this much taller than the picture asked for.
pub const LEGEND_HEIGHT: u32 = 46;
/// Font scale of the legend's labels.
const LABEL_SCALE: u32 = 2;
/// Margin around the legend's ramp bar.
const MARGIN: u32 = 6;
/// Height of the legend's ramp bar.
const BAR: u32 = 8;
/// The row, from the strip's top, of the labels under the ramp.
const LABELS: u32 = MARGIN + BAR + 3;
/// The row, from the strip's top, of the caption under the labels.
const CAPTION: u32 = LABELS + FONT_HEIGHT * LABEL_SCALE + 4;
// The caption fits in the strip.
const _: () = assert!(CAPTION + FONT_HEIGHT * LABEL_SCALE + 5 <= LEGEND_HEIGHT);

/// The legend's captions, longest first: the widest that fits is drawn.
const CAPTIONS: [&str; 4] = [
    "LOG SCALE: NODES VISITED + TRIANGLES TESTED PER RAY",
    "LOG SCALE: NODES + TRIANGLES PER RAY",
    "LOG: NODES + TRIANGLES",
    "LOG",
];

/// The ramp's stops, evenly spaced from cheap (dark) to expensive (bright).
const RAMP: [[f32; 3]; 5] = [
    [0.0, 0.0, 4.0],
    [87.0, 16.0, 110.0],
    [188.0, 55.0, 84.0],
    [249.0, 142.0, 9.0],
    [252.0, 255.0, 164.0],
];

/// A heatmap and the costs its ramp spans.
#[derive(Clone, Debug, PartialEq)]
pub struct Heatmap {
    /// The picture, `LEGEND_HEIGHT` rows taller than asked, the legend at the bottom.
    pub image: Image,
    /// The smallest per-pixel cost (nodes visited + triangles tested).
    pub min: u32,
    /// The largest per-pixel cost.
    pub max: u32,
    /// The mean per-pixel cost.
    pub mean: f64,
}

/// The traversal cost of every camera ray of `params` in `tree` (single
/// rays, [`TriangleTree::counting`]); `progress` is called once
/// per image row.
pub fn render_heatmap(
    tree: &TriangleTree<'_>,
    params: &RenderParams,
    progress: &(dyn Fn() + Sync),
) -> Heatmap {
    let (w, h) = (params.width, params.height);
    let costs = in_tiles(w, h, (1, 1), progress, |coords, out: &mut [u32]| {
        for (&[x, y], o) in coords.iter().zip(out) {
            let (_, c) = tree.counting().closest_hit(&params.camera.ray(x, y, w, h));
            *o = c.nodes.saturating_add(c.triangles);
        }
    });
    let min = costs.iter().copied().min().unwrap_or(0);
    let max = costs.iter().copied().max().unwrap_or(0);
    let mean = costs.iter().map(|&c| f64::from(c)).sum::<f64>() / costs.len().max(1) as f64;
    let scale = LogScale::new(min, max);
    let mut pixels: Vec<[u8; 3]> = costs.iter().map(|&c| ramp(scale.fraction(c))).collect();
    pixels.resize((w * (h + LEGEND_HEIGHT)) as usize, BACKGROUND);
    let mut image = Image {
        width: w,
        height: h + LEGEND_HEIGHT,
        pixels,
    };
    draw_legend(&mut image, h, &scale);
    Heatmap {
        image,
        min,
        max,
        mean,
    }
}

/// Costs from `min` to `max` mapped to `[0, 1]` by `ln(1 + cost - min)`.
struct LogScale {
    min: u32,
    max: u32,
    /// `ln(1 + max - min)`, at least `ln 2`.
    top: f32,
}

impl LogScale {
    fn new(min: u32, max: u32) -> LogScale {
        LogScale {
            min,
            max,
            top: ((max - min) as f32).max(1.0).ln_1p(),
        }
    }

    /// Where `cost` sits on the ramp.
    fn fraction(&self, cost: u32) -> f32 {
        (cost.saturating_sub(self.min) as f32).ln_1p() / self.top
    }

    /// The cost at ramp position `f` (the legend's middle label).
    fn cost_at(&self, f: f32) -> u32 {
        self.min + ((f * self.top).exp_m1().round() as u32).min(self.max - self.min)
    }
}

/// The ramp's colour at `f` in `[0, 1]` (clamped).
fn ramp(f: f32) -> [u8; 3] {
    let x = f.clamp(0.0, 1.0) * (RAMP.len() - 1) as f32;
    let i = (x as usize).min(RAMP.len() - 2);
    let frac = x - i as f32;
    std::array::from_fn(|c| (RAMP[i][c] + (RAMP[i + 1][c] - RAMP[i][c]) * frac + 0.5) as u8)
}

/// The ramp bar across the strip starting at row `top`, labelled with the
/// minimum under its left end, the cost at its middle under the middle,
/// and the maximum under its right end.
fn draw_legend(img: &mut Image, top: u32, scale: &LogScale) {
    let (x0, x1) = (MARGIN, img.width.saturating_sub(MARGIN));
    let span = (x1.saturating_sub(x0)).max(2) - 1;
    for x in x0..x1 {
        let colour = ramp((x - x0) as f32 / span as f32);
        for y in top + MARGIN..top + MARGIN + BAR {
            img.set(x, y, colour);
        }
    }
    let y = top + LABELS;
    let white = [235, 235, 235];
    draw_text(img, &scale.min.to_string(), x0, y, LABEL_SCALE, white);
    let mid = scale.cost_at(0.5).to_string();
    let x = (x0 + x1).saturating_sub(text_width(&mid, LABEL_SCALE)) / 2;
    draw_text(img, &mid, x, y, LABEL_SCALE, white);
    let max = scale.max.to_string();
    let x = x1.saturating_sub(text_width(&max, LABEL_SCALE));
    draw_text(img, &max, x, y, LABEL_SCALE, white);
    if let Some(caption) = caption(x1.saturating_sub(x0)) {
        draw_text(img, caption, x0, top + CAPTION, LABEL_SCALE, white);
    }
}

/// The longest caption at most `width` pixels wide, if any is.
fn caption(width: u32) -> Option<&'static str> {
    CAPTIONS
        .into_iter()
        .find(|c| text_width(c, LABEL_SCALE) <= width)
}

#[cfg(test)]
mod tests {
    use super::super::font::can_draw;
    use super::*;

    #[test]
    fn ramp_runs_dark_to_bright() {
        let lum = |c: [u8; 3]| c.iter().map(|&v| u32::from(v)).sum::<u32>();
        let steps: Vec<u32> = (0..=20).map(|i| lum(ramp(i as f32 / 20.0))).collect();
        assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
        assert_eq!(ramp(-1.0), ramp(0.0));
        assert_eq!(ramp(2.0), [252, 255, 164]);
    }

    #[test]
    fn the_caption_says_log_scale_and_what_is_counted() {
        assert!(
            CAPTIONS.iter().all(|c| can_draw(c)),
            "a letter without a glyph"
        );
        assert_eq!(caption(640), Some(CAPTIONS[0]));
        assert_eq!(caption(300), Some(CAPTIONS[1]));
        assert_eq!(caption(10), None);
        // Drawn in its rows under the labels, in the labels' white.
        let (w, h) = (640, 10);
        let mut img = Image::filled(w, h + LEGEND_HEIGHT, BACKGROUND);
        draw_legend(&mut img, h, &LogScale::new(1, 100));
        let mut expect = Image::filled(w, h + LEGEND_HEIGHT, BACKGROUND);
        draw_text(
            &mut expect,
            CAPTIONS[0],
            MARGIN,
            h + CAPTION,
            LABEL_SCALE,
            [235; 3],
        );
        let rows = |i: &Image| i.pixels[((h + CAPTION) * w) as usize..].to_vec();
        assert_eq!(rows(&img), rows(&expect));
        assert!(rows(&img).iter().filter(|&&p| p == [235; 3]).count() > 500);
    }

    #[test]
    fn log_scale_spans_min_to_max() {
        let s = LogScale::new(3, 403);
        assert_eq!(s.fraction(3), 0.0);
        assert!((s.fraction(403) - 1.0).abs() < 1e-6);
        assert_eq!(s.cost_at(0.0), 3);
        assert_eq!(s.cost_at(1.0), 403);
        assert_eq!(s.cost_at(0.5), 3 + 19); // sqrt(401) - 1 ≈ 19
        let flat = LogScale::new(7, 7);
        assert_eq!((flat.fraction(7), flat.cost_at(0.5)), (0.0, 7));
    }
}
