//! A rendered image ([`Image`]): premultiplied float pixels read back
//! from the colour target, straight 8-bit RGBA and PNG out.

use super::error::RenderError;

/// A rendered image: straight (un-premultiplied) RGBA, 8 bits, rows top to bottom.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Premultiplied float RGBA after compositing over the background.
    pub premultiplied: Vec<[f32; 4]>,
}

impl Image {
    /// Straight RGBA, 8 bits per channel.
    pub fn rgba8(&self) -> Vec<u8> {
        let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
        self.premultiplied
            .iter()
            .flat_map(|p| {
                let a = p[3];
                if a <= 0.0 {
                    [0, 0, 0, 0]
                } else {
                    [q(p[0] / a), q(p[1] / a), q(p[2] / a), q(a)]
                }
            })
            .collect()
    }

    /// The premultiplied float pixel at (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        self.premultiplied[(y * self.width + x) as usize]
    }

    /// Encodes a PNG (straight RGBA, 8 bits).
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        w.write_image_data(&self.rgba8())
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        w.finish()
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        Ok(out)
    }
}

/// A half float (the Rgba16Float target's channels) as `f32`.
pub(super) fn f16_to_f32(h: u16) -> f32 {
    let s = ((h >> 15) as u32) << 31;
    let e = (h >> 10 & 0x1f) as u32;
    let m = (h & 0x3ff) as u32;
    let bits = match (e, m) {
        (0, 0) => s,
        (0, _) => {
            // Subnormal: normalise.
            let mut e = 127 - 15 + 1;
            let mut m = m;
            while m & 0x400 == 0 {
                m <<= 1;
                e -= 1;
            }
            s | (e as u32) << 23 | (m & 0x3ff) << 13
        }
        (0x1f, _) => s | 0xff << 23 | m << 13,
        _ => s | (e + 127 - 15) << 23 | m << 13,
    };
    f32::from_bits(bits)
}
