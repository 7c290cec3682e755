//! An 8-bit RGB image and its PNG file.

use crate::io::Output;
use std::path::Path;

/// An 8-bit sRGB image, row 0 at the top.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels, row by row.
    pub pixels: Vec<[u8; 3]>,
}

impl Image {
    /// A `width` x `height` image filled with `colour`.
    #[must_use]
    pub fn filled(width: u32, height: u32, colour: [u8; 3]) -> Image {
        Image {
            width,
            height,
            pixels: vec![colour; width as usize * height as usize],
        }
    }

    /// The pixel at `(x, y)`, `None` outside the image.
    #[must_use]
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        (x < self.width && y < self.height)
            .then(|| self.pixels[y as usize * self.width as usize + x as usize])
    }

    /// Sets the pixel at `(x, y)`; nothing outside the image.
    pub fn set(&mut self, x: u32, y: u32, colour: [u8; 3]) {
        if x < self.width && y < self.height {
            self.pixels[y as usize * self.width as usize + x as usize] = colour;
        }
    }

    /// Writes the image as an 8-bit RGB PNG, as an [`Output`] (a failed
    /// write leaves the previous picture in place).
    ///
    /// # Errors
    /// An I/O or encoding error, naming the file.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let fail = |e: &dyn std::fmt::Display| format!("{}: cannot write PNG: {e}", path.display());
        let mut out = Output::create(path).map_err(|e| e.to_string())?;
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| fail(&e))?;
        writer
            .write_image_data(self.pixels.as_flattened())
            .map_err(|e| fail(&e))?;
        writer.finish().map_err(|e| fail(&e))?;
        out.commit().map_err(|e| e.to_string())
    }
}
