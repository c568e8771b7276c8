//! The self-contained HTML report: sections of text, tables and inline SVG
//! figures, with the style sheet inline, so the page opens anywhere without
//! network access.

pub mod svg;

use svg::escape;

/// One block of a report section.
#[derive(Debug, Clone)]
enum Block {
    Paragraph(String),
    Table {
        caption: String,
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    Figure {
        svg: String,
        caption: String,
    },
    Code(String),
}

/// A titled section of the report.
#[derive(Debug, Clone)]
pub struct Section {
    title: String,
    blocks: Vec<Block>,
}

impl Section {
    /// An empty section.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            blocks: Vec::new(),
        }
    }

    /// Adds a paragraph of plain text (escaped).
    pub fn paragraph(&mut self, text: impl AsRef<str>) -> &mut Self {
        self.blocks.push(Block::Paragraph(escape(text.as_ref())));
        self
    }

    /// Adds a table; cells are plain text (escaped).
    pub fn table(
        &mut self,
        caption: impl Into<String>,
        header: &[&str],
        rows: Vec<Vec<String>>,
    ) -> &mut Self {
        self.blocks.push(Block::Table {
            caption: caption.into(),
            header: header.iter().map(|h| h.to_string()).collect(),
            rows,
        });
        self
    }

    /// Adds an inline SVG figure with a caption.
    pub fn figure(&mut self, svg: String, caption: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Figure {
            svg,
            caption: caption.into(),
        });
        self
    }

    /// Adds a block of preformatted text (commands to rerun a step).
    pub fn code(&mut self, text: impl AsRef<str>) -> &mut Self {
        self.blocks.push(Block::Code(escape(text.as_ref())));
        self
    }
}

/// A whole report page.
#[derive(Debug, Clone, Default)]
pub struct Report {
    title: String,
    subtitle: String,
    sections: Vec<Section>,
}

const STYLE: &str = "body{font-family:sans-serif;max-width:980px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}\
h1{font-size:1.6em;margin-bottom:0.2em}h2{border-bottom:1px solid #ccc;padding-bottom:0.2em;margin-top:2em}\
.subtitle{color:#555}table{border-collapse:collapse;margin:1em 0;font-size:0.92em}\
caption{text-align:left;font-weight:bold;padding:0.3em 0}th,td{border:1px solid #ccc;padding:0.25em 0.6em;text-align:right}\
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}figure{margin:1.2em 0}\
figcaption{color:#444;font-size:0.9em}pre{background:#f6f6f6;padding:0.8em;overflow-x:auto}\
nav ul{columns:2}";

impl Report {
    /// An empty report.
    pub fn new(title: impl Into<String>, subtitle: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            subtitle: subtitle.into(),
            sections: Vec::new(),
        }
    }

    /// Appends a section.
    pub fn push(&mut self, section: Section) {
        self.sections.push(section);
    }

    /// Number of figures in the report.
    pub fn figure_count(&self) -> usize {
        self.sections
            .iter()
            .flat_map(|s| &s.blocks)
            .filter(|b| matches!(b, Block::Figure { .. }))
            .count()
    }

    /// The whole page as HTML text.
    pub fn to_html(&self) -> String {
        let mut html = String::new();
        html.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
        html.push_str(&format!(
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{}</title><style>{STYLE}</style></head><body>",
            escape(&self.title)
        ));
        html.push_str(&format!(
            "<h1>{}</h1><p class=\"subtitle\">{}</p>",
            escape(&self.title),
            escape(&self.subtitle)
        ));
        html.push_str("<nav><ul>");
        for (i, s) in self.sections.iter().enumerate() {
            html.push_str(&format!(
                "<li><a href=\"#s{i}\">{}</a></li>",
                escape(&s.title)
            ));
        }
        html.push_str("</ul></nav>");
        let mut figure_number = 0;
        for (i, s) in self.sections.iter().enumerate() {
            html.push_str(&format!("<h2 id=\"s{i}\">{}</h2>", escape(&s.title)));
            for block in &s.blocks {
                match block {
                    Block::Paragraph(p) => html.push_str(&format!("<p>{p}</p>")),
                    Block::Code(c) => html.push_str(&format!("<pre>{c}</pre>")),
                    Block::Table {
                        caption,
                        header,
                        rows,
                    } => {
                        html.push_str(&format!(
                            "<table><caption>{}</caption><tr>",
                            escape(caption)
                        ));
                        for h in header {
                            html.push_str(&format!("<th>{}</th>", escape(h)));
                        }
                        html.push_str("</tr>");
                        for row in rows {
                            html.push_str("<tr>");
                            for cell in row {
                                html.push_str(&format!("<td>{}</td>", escape(cell)));
                            }
                            html.push_str("</tr>");
                        }
                        html.push_str("</table>");
                    }
                    Block::Figure { svg, caption } => {
                        figure_number += 1;
                        html.push_str(&format!(
                            "<figure>{svg}<figcaption>Figure {figure_number}. {}</figcaption></figure>",
                            escape(caption)
                        ));
                    }
                }
            }
        }
        html.push_str("</body></html>\n");
        html
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_is_self_contained_and_counts_figures() {
        let mut r = Report::new("T <1>", "sub");
        let mut s = Section::new("Geometry");
        s.paragraph("a & b")
            .table(
                "t",
                &["name", "value"],
                vec![vec!["d3".into(), "1.0".into()]],
            )
            .figure(
                svg::line_chart(
                    "c",
                    "x",
                    "y",
                    &[svg::Series::new("s", vec![(0.0, 1.0)])],
                    svg::YScale::Linear,
                ),
                "cap",
            )
            .code("flexcal fk --robot ur10");
        r.push(s);
        let html = r.to_html();
        assert_eq!(r.figure_count(), 1);
        assert!(html.contains("T &lt;1&gt;") && html.contains("a &amp; b"));
        assert!(
            !html.contains("http://")
                || html.matches("http://").count()
                    == html.matches("xmlns=\"http://www.w3.org/2000/svg\"").count()
        );
        assert!(!html.contains("<script src") && !html.contains("<link"));
    }
}
