//! Image re-encoding for providers: PNG or JPEG, downscaled to a maximum side.

use std::io::Cursor;

use base64::Engine;

use crate::vlm::config::ImageFormat;

/// An image ready to send.
#[derive(Debug, Clone)]
pub struct Encoded {
    pub bytes: Vec<u8>,
    pub format: ImageFormat,
}

impl Encoded {
    pub fn mime(&self) -> &'static str {
        match self.format {
            ImageFormat::Png => "image/png",
            ImageFormat::Jpeg => "image/jpeg",
        }
    }

    /// The short format name Bedrock's Converse API expects.
    pub fn short(&self) -> &'static str {
        match self.format {
            ImageFormat::Png => "png",
            ImageFormat::Jpeg => "jpeg",
        }
    }

    pub fn base64(&self) -> String {
        base64::engine::general_purpose::STANDARD.encode(&self.bytes)
    }
}

/// Re-encode `src` (any format `image` reads) as `format`, downscaled so its longest side is at
/// most `max_side`. A PNG that needs no change is passed through byte for byte.
pub fn encode(src: &[u8], format: ImageFormat, max_side: Option<u32>, jpeg_quality: u8) -> Result<Encoded, String> {
    let reader = || {
        image::ImageReader::new(Cursor::new(src))
            .with_guessed_format()
            .map_err(|e| format!("cannot read the scene image: {e}"))
    };
    let fits = |(w, h): (u32, u32)| max_side.is_none_or(|m| w.max(h) <= m);
    // The common case (PNG in, PNG out, small enough) needs only the header, not a decode.
    if format == ImageFormat::Png && reader()?.format() == Some(image::ImageFormat::Png) {
        let dims = reader()?.into_dimensions().map_err(|e| format!("cannot read the scene image: {e}"))?;
        if fits(dims) {
            return Ok(Encoded { bytes: src.to_vec(), format });
        }
    }
    let img = reader()?.decode().map_err(|e| format!("cannot decode the scene image: {e}"))?;
    let too_big = !fits((img.width(), img.height()));
    let img = match max_side {
        Some(m) if too_big => img.resize(m, m, image::imageops::FilterType::Lanczos3),
        _ => img,
    };
    let mut out = Vec::new();
    match format {
        ImageFormat::Png => img.write_to(&mut Cursor::new(&mut out), image::ImageFormat::Png),
        ImageFormat::Jpeg => {
            // JPEG has no alpha channel.
            let rgb = img.to_rgb8();
            let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, jpeg_quality);
            enc.encode_image(&rgb)
        }
    }
    .map_err(|e| format!("cannot encode the scene image: {e}"))?;
    Ok(Encoded { bytes: out, format })
}

#[cfg(test)]
pub(crate) fn test_png(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x % 256) as u8, (y % 256) as u8, 128]));
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_passes_through_unchanged() {
        let png = test_png(64, 32);
        let e = encode(&png, ImageFormat::Png, Some(64), 90).unwrap();
        assert_eq!(e.bytes, png);
        assert_eq!(e.mime(), "image/png");
    }

    #[test]
    fn downscales_keeping_aspect() {
        let e = encode(&test_png(200, 100), ImageFormat::Png, Some(50), 90).unwrap();
        let img = image::load_from_memory(&e.bytes).unwrap();
        assert_eq!((img.width(), img.height()), (50, 25));
    }

    #[test]
    fn jpeg_output() {
        let e = encode(&test_png(40, 30), ImageFormat::Jpeg, None, 80).unwrap();
        assert_eq!(&e.bytes[..2], &[0xFF, 0xD8]);
        assert_eq!((e.mime(), e.short()), ("image/jpeg", "jpeg"));
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(encode(b"not an image", ImageFormat::Png, None, 90).unwrap_err().starts_with("cannot"));
    }
}
