//! Everything the harness writes: atomic files, CSV, run metadata, figures (a JSON twin and a
//! PNG from one description, in one style table), the report page and the landing page.
//!
//! Every file is written to a temporary name beside its target and renamed into place, so an
//! interrupted run leaves the previous version or the new one, never half a file.

pub mod figure;
pub mod folder;
pub mod landing;
pub mod meta;
pub mod render;
pub mod report;
pub mod results;
pub mod style;

use std::fs;
use std::path::Path;

use anyhow::{Context, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The distinct values of `items` in the order they first appear (the datasets, methods or
/// families of a results file, for tables and plots).
pub fn distinct<'a>(items: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for item in items {
        if !out.iter().any(|o| o == item) {
            out.push(item.to_owned());
        }
    }
    out
}

/// Escapes text for HTML element content and attribute values.
pub fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An HTML document as every page pointsight writes it: UTF-8, the viewport for small screens,
/// `generator` naming the command that wrote it, `title` (escaped here), `head` added to the
/// head (a style sheet), then `body`.
pub fn html_document(generator: &str, title: &str, head: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"{generator}\">\n\
         <title>{}</title>\n{head}</head>\n<body>\n{body}</body>\n</html>\n",
        escape_html(title)
    )
}

/// `script` as an inline `<script>` element, `</script` escaped so that nothing in it ends the
/// element early.
pub fn script_element(script: &str) -> String {
    format!(
        "<script>{}</script>",
        script.replace("</script", "<\\/script")
    )
}

/// A page its script draws from its data (the results and viewer pages): `data` as the JSON
/// element `pointsight-data` (`</` escaped: JSON and JavaScript both read `<\/` as `</`), then
/// `script`.
pub fn data_page(
    generator: &str,
    title: &str,
    data: &serde_json::Value,
    script: &str,
) -> Result<String> {
    let json = serde_json::to_string(data)?.replace("</", "<\\/");
    Ok(html_document(
        generator,
        title,
        "",
        &format!(
            "<script id=\"pointsight-data\" type=\"application/json\">{json}</script>\n{}\n",
            script_element(script)
        ),
    ))
}

/// Relative link targets in a markdown text (for checking that they exist).
pub fn link_targets(markdown: &str) -> Vec<String> {
    let mut targets = Vec::new();
    let mut rest = markdown;
    while let Some(pos) = rest.find("](") {
        rest = &rest[pos + 2..];
        if let Some(end) = rest.find(')') {
            let t = &rest[..end];
            if !(t.starts_with("http://") || t.starts_with("https://") || t.starts_with('#')) {
                targets.push(t.to_owned());
            }
        }
    }
    targets
}

/// Writes `bytes` to `path` atomically (creating its folder): [`cloud::io::atomic`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    cloud::io::atomic::write(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Writes `rows` as CSV with a header (from the row type's field names), atomically; a
/// table without rows is its header alone, so that it reads as an empty table.
pub fn write_csv<T: Serialize + DeserializeOwned>(path: &Path, rows: &[T]) -> Result<()> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    if rows.is_empty() {
        writer.write_record(header::<T>())?;
    }
    for row in rows {
        writer.serialize(row)?;
    }
    let bytes = writer.into_inner().context("cannot finish the CSV")?;
    write_atomic(path, &bytes)
}

/// The column names of row type `T`: its fields as serde names them, read from what its
/// `Deserialize` asks for (the header `csv` writes before a first row).
pub fn header<T: DeserializeOwned>() -> Vec<&'static str> {
    /// A deserializer that only records the fields of the struct asked for.
    struct Fields(Vec<&'static str>);
    #[derive(Debug)]
    struct Done;
    impl std::fmt::Display for Done {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("fields recorded")
        }
    }
    impl std::error::Error for Done {}
    impl serde::de::Error for Done {
        fn custom<M: std::fmt::Display>(_: M) -> Self {
            Done
        }
    }
    impl<'de> serde::Deserializer<'de> for &mut Fields {
        type Error = Done;
        fn deserialize_any<V: serde::de::Visitor<'de>>(self, _: V) -> Result<V::Value, Done> {
            Err(Done)
        }
        fn deserialize_struct<V: serde::de::Visitor<'de>>(
            self,
            _name: &'static str,
            fields: &'static [&'static str],
            _visitor: V,
        ) -> Result<V::Value, Done> {
            self.0.extend_from_slice(fields);
            Err(Done)
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
            byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
            identifier ignored_any
        }
    }
    let mut fields = Fields(Vec::new());
    let _ = T::deserialize(&mut fields);
    fields.0
}

/// Reads a CSV written by [`write_csv`].
pub fn read_csv<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>> {
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("cannot read {}", path.display()))?;
    reader
        .deserialize()
        .collect::<Result<Vec<T>, _>>()
        .with_context(|| format!("malformed {}", path.display()))
}

/// Writes an RGB8 image as PNG, atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    use super::*;

    #[test]
    fn distinct_keeps_first_appearance_order() {
        assert_eq!(distinct(["b", "a", "b", "c", "a"]), ["b", "a", "c"]);
        assert!(distinct([]).is_empty());
    }

    #[derive(Debug, Serialize, Deserialize, PartialEq)]
    struct Row {
        dataset: String,
        f1: f64,
    }

    #[test]
    fn csv_round_trip_and_atomic_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/results.csv");
        let rows = vec![Row {
            dataset: "bunny".into(),
            f1: 0.5,
        }];
        write_csv(&path, &rows).unwrap();
        write_csv(&path, &rows).unwrap();
        assert_eq!(read_csv::<Row>(&path).unwrap(), rows);
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("dataset,f1\n"));
        // No temporary file is left behind.
        assert_eq!(fs::read_dir(path.parent().unwrap()).unwrap().count(), 1);
    }

    #[test]
    fn an_empty_table_is_its_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.csv");
        write_csv::<Row>(&path, &[]).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "dataset,f1\n");
        assert!(read_csv::<Row>(&path).unwrap().is_empty());
    }

    #[test]
    fn png_is_valid() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.png");
        write_png(&path, 2, 1, &[255, 0, 0, 0, 255, 0]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.get_pixel(1, 0).0, [0, 255, 0]);
    }
}
