//! A plotters drawing backend that writes inline SVG with named groups.
//!
//! Plotters draws primitives only (lines, polylines, rectangles, circles,
//! polygons, text). To make a chart's parts findable, [`SvgCanvas`] also
//! writes `<g>` elements around them. Group boundaries travel through
//! plotters' own drawing path as elements ([`GroupMark`]) that implement
//! plotters' documented custom-element traits (`PointCollection` and
//! `Drawable`) for this backend only; when plotters draws one, the backend
//! opens or closes a group. Elements are drawn in call order, so a group
//! holds exactly what was drawn between its marks.
//!
//! The canvas writes the root `<svg>` element itself, with the attributes
//! and `<title>` the page needs and without the fixed size and namespace a
//! stand-alone SVG file would carry: the page scales charts with CSS, and
//! inline SVG in HTML needs no namespace declaration. Nothing is rewritten
//! after drawing.
//!
//! Unbalanced groups are errors: closing a group that is not open fails at
//! once, and [`DrawingBackend::present`] fails when groups are left open.

use std::fmt::{Display, Write as _};
use std::iter::Empty;

use plotters::element::{Drawable, PointCollection};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontStyle, FontTransform,
};

use crate::format::escape;

/// Plotters' text sizes are this factor larger than the SVG font size (the
/// convention of plotters' own SVG backend and of its font-free text-size
/// estimate, which layouts are computed with).
pub(crate) const FONT_SCALE: f64 = 1.24;

/// Why the canvas refused a drawing call.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum SvgError {
    /// A group was closed while none was open.
    #[error("a group was closed while none was open")]
    CloseWithoutOpen,
    /// The drawing was finished with groups still open.
    #[error("the drawing was finished with {open} group(s) still open")]
    LeftOpen {
        /// How many groups were open.
        open: usize,
    },
}

type Result<T = ()> = std::result::Result<T, DrawingErrorKind<SvgError>>;

/// The attributes of a `<g>` (or of the root `<svg>`): names are fixed by
/// the code, values are escaped when written.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Group {
    attrs: Vec<(&'static str, String)>,
}

impl Group {
    /// A group with a `class`.
    pub(crate) fn class(class: &str) -> Group {
        Group::default().attr("class", class)
    }

    /// Adds an attribute.
    pub(crate) fn attr(mut self, name: &'static str, value: impl Display) -> Group {
        self.attrs.push((name, value.to_string()));
        self
    }

    fn write_attrs(&self, out: &mut String) {
        for (name, value) in &self.attrs {
            let _ = write!(out, " {name}=\"{}\"", escape(value));
        }
    }
}

/// A group boundary, drawn like any plotters element:
/// `root.draw(&GroupMark::Open(group))`, then the group's content, then
/// `root.draw(&GroupMark::Close)`. It has no points, so no coordinate
/// system moves or clips it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum GroupMark {
    /// Opens a `<g>` with these attributes.
    Open(Group),
    /// Closes the innermost open `<g>`.
    Close,
}

impl<'a> PointCollection<'a, (i32, i32)> for &'a GroupMark {
    type Point = &'a (i32, i32);
    type IntoIter = Empty<&'a (i32, i32)>;

    fn point_iter(self) -> Self::IntoIter {
        std::iter::empty()
    }
}

impl Drawable<SvgCanvas<'_>> for GroupMark {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        _points: I,
        backend: &mut SvgCanvas<'_>,
        _parent_dim: (u32, u32),
    ) -> Result {
        match self {
            GroupMark::Open(group) => {
                backend.open_group(group);
                Ok(())
            }
            GroupMark::Close => backend.close_group(),
        }
    }
}

/// Writes one SVG document into a string: the root `<svg>` and its
/// `<title>` when created, the drawn elements and groups as they come, and
/// `</svg>` when presented (or dropped).
pub(crate) struct SvgCanvas<'a> {
    out: &'a mut String,
    size: (u32, u32),
    open_groups: usize,
    finished: bool,
}

impl<'a> SvgCanvas<'a> {
    /// Starts a document of `size` pixels (its `viewBox`) in `out`, with
    /// the root attributes `root` and a `<title>` with id `title_id`.
    pub(crate) fn new(
        out: &'a mut String,
        size: (u32, u32),
        root: &Group,
        title_id: &str,
        title: &str,
    ) -> SvgCanvas<'a> {
        out.push_str("<svg");
        root.write_attrs(out);
        let _ = writeln!(
            out,
            " viewBox=\"0 0 {} {}\"><title id=\"{}\">{}</title>",
            size.0,
            size.1,
            escape(title_id),
            escape(title)
        );
        SvgCanvas {
            out,
            size,
            open_groups: 0,
            finished: false,
        }
    }

    fn open_group(&mut self, group: &Group) {
        self.out.push_str("<g");
        group.write_attrs(self.out);
        self.out.push('>');
        self.open_groups += 1;
    }

    fn close_group(&mut self) -> Result {
        if self.open_groups == 0 {
            return Err(DrawingErrorKind::DrawingError(SvgError::CloseWithoutOpen));
        }
        self.out.push_str("</g>");
        self.open_groups -= 1;
        Ok(())
    }

    /// Starts an empty element: `<name`.
    fn start(&mut self, name: &str) {
        let _ = write!(self.out, "<{name}");
    }

    /// Writes an attribute whose value needs no escaping (numbers, fixed
    /// keywords, colours).
    fn attr(&mut self, name: &str, value: impl Display) {
        let _ = write!(self.out, " {name}=\"{value}\"");
    }

    /// Ends an empty element.
    fn end(&mut self) {
        self.out.push_str("/>\n");
    }

    fn points(&mut self, points: impl IntoIterator<Item = BackendCoord>) {
        self.out.push_str(" points=\"");
        for (x, y) in points {
            let _ = write!(self.out, "{x},{y} ");
        }
        self.out.push('"');
    }
}

/// `#RRGGBB`.
struct Hex(BackendColor);

impl Display for Hex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (r, g, b) = self.0.rgb;
        write!(f, "#{r:02X}{g:02X}{b:02X}")
    }
}

impl DrawingBackend for SvgCanvas<'_> {
    type ErrorType = SvgError;

    fn get_size(&self) -> (u32, u32) {
        self.size
    }

    fn ensure_prepared(&mut self) -> Result {
        Ok(())
    }

    fn present(&mut self) -> Result {
        if self.finished {
            return Ok(());
        }
        if self.open_groups > 0 {
            return Err(DrawingErrorKind::DrawingError(SvgError::LeftOpen {
                open: self.open_groups,
            }));
        }
        self.out.push_str("</svg>\n");
        self.finished = true;
        Ok(())
    }

    fn draw_pixel(&mut self, (x, y): BackendCoord, color: BackendColor) -> Result {
        self.draw_rect((x, y), (x + 1, y + 1), &color, true)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        (x1, y1): BackendCoord,
        (x2, y2): BackendCoord,
        style: &S,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        self.start("line");
        self.attr("opacity", color.alpha);
        self.attr("stroke", Hex(color));
        self.attr("stroke-width", style.stroke_width());
        self.attr("x1", x1);
        self.attr("y1", y1);
        self.attr("x2", x2);
        self.attr("y2", y2);
        self.end();
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        (x0, y0): BackendCoord,
        (x1, y1): BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        self.start("rect");
        self.attr("x", x0);
        self.attr("y", y0);
        self.attr("width", x1 - x0);
        self.attr("height", y1 - y0);
        self.attr("opacity", color.alpha);
        if fill {
            self.attr("fill", Hex(color));
            self.attr("stroke", "none");
        } else {
            self.attr("fill", "none");
            self.attr("stroke", Hex(color));
        }
        self.end();
        Ok(())
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        self.start("polyline");
        self.attr("fill", "none");
        self.attr("opacity", color.alpha);
        self.attr("stroke", Hex(color));
        self.attr("stroke-width", style.stroke_width());
        self.points(path);
        self.end();
        Ok(())
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vertices: I,
        style: &S,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        self.start("polygon");
        self.attr("opacity", color.alpha);
        self.attr("fill", Hex(color));
        self.points(vertices);
        self.end();
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        (cx, cy): BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        self.start("circle");
        self.attr("cx", cx);
        self.attr("cy", cy);
        self.attr("r", radius);
        self.attr("opacity", color.alpha);
        if fill {
            self.attr("fill", Hex(color));
            self.attr("stroke", "none");
        } else {
            self.attr("fill", "none");
            self.attr("stroke", Hex(color));
        }
        self.attr("stroke-width", style.stroke_width());
        self.end();
        Ok(())
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        (x, y): BackendCoord,
    ) -> Result {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let anchor = style.anchor();
        self.start("text");
        self.attr("x", x);
        self.attr("y", y);
        // The baseline offset that puts the anchor point at the top, middle
        // or bottom of the text.
        self.attr(
            "dy",
            match anchor.v_pos {
                VPos::Top => "0.76em",
                VPos::Center => "0.5ex",
                VPos::Bottom => "-0.5ex",
            },
        );
        self.attr(
            "text-anchor",
            match anchor.h_pos {
                HPos::Left => "start",
                HPos::Center => "middle",
                HPos::Right => "end",
            },
        );
        self.attr("font-family", escape(style.family().as_str()));
        self.attr("font-size", style.size() / FONT_SCALE);
        self.attr("opacity", color.alpha);
        self.attr("fill", Hex(color));
        match style.style() {
            FontStyle::Normal => {}
            FontStyle::Bold => self.attr("font-weight", "bold"),
            other => self.attr("font-style", other.as_str()),
        }
        let degrees = match style.transform() {
            FontTransform::Rotate90 => Some(90),
            FontTransform::Rotate180 => Some(180),
            FontTransform::Rotate270 => Some(270),
            _ => None,
        };
        if let Some(d) = degrees {
            self.attr("transform", format_args!("rotate({d}, {x}, {y})"));
        }
        let _ = write!(self.out, ">\n{}\n</text>\n", escape(text));
        Ok(())
    }
}

impl Drop for SvgCanvas<'_> {
    /// Ends the document if it was not presented; a drop cannot report the
    /// open-groups error, so open groups are closed.
    fn drop(&mut self) {
        if !self.finished {
            for _ in 0..self.open_groups {
                self.out.push_str("</g>");
            }
            self.open_groups = 0;
            let _ = self.present();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    fn drawn(f: impl FnOnce(&DrawingArea<SvgCanvas<'_>, plotters::coord::Shift>)) -> String {
        let mut out = String::new();
        {
            let canvas = SvgCanvas::new(&mut out, (40, 30), &Group::class("chart"), "t", "A & B");
            let root = canvas.into_drawing_area();
            f(&root);
        }
        out
    }

    #[test]
    fn groups_hold_what_was_drawn_between_their_marks() {
        let out = drawn(|root| {
            root.draw(&GroupMark::Open(
                Group::class("series").attr("data-series", "a\"b"),
            ))
            .unwrap();
            root.draw(&Circle::new((5, 6), 2, BLACK.filled())).unwrap();
            root.draw(&GroupMark::Close).unwrap();
            root.draw(&Circle::new((7, 8), 2, BLACK.filled())).unwrap();
            root.present().unwrap();
        });
        assert!(out.starts_with(
            "<svg class=\"chart\" viewBox=\"0 0 40 30\"><title id=\"t\">A &amp; B</title>\n"
        ));
        let open = out
            .find("<g class=\"series\" data-series=\"a&quot;b\">")
            .unwrap();
        let first = out.find("cx=\"5\"").unwrap();
        let close = out.find("</g>").unwrap();
        let second = out.find("cx=\"7\"").unwrap();
        assert!(open < first && first < close && close < second, "{out}");
        assert!(out.ends_with("</svg>\n"));
        assert_eq!(out.matches("</svg>").count(), 1);
    }

    #[test]
    fn sub_areas_do_not_move_group_marks() {
        let out = drawn(|root| {
            let (_, right) = root.split_horizontally(20);
            right.draw(&GroupMark::Open(Group::class("x"))).unwrap();
            right.draw(&Circle::new((1, 1), 1, BLACK)).unwrap();
            right.draw(&GroupMark::Close).unwrap();
        });
        assert!(out.contains("<g class=\"x\"><circle cx=\"21\""), "{out}");
    }

    #[test]
    fn unbalanced_groups_are_errors() {
        drawn(|root| {
            let err = root.draw(&GroupMark::Close).unwrap_err();
            assert!(err.to_string().contains("none was open"), "{err}");
            root.draw(&GroupMark::Open(Group::class("x"))).unwrap();
            let err = root.present().unwrap_err();
            assert!(err.to_string().contains("1 group(s) still open"), "{err}");
        });
    }

    #[test]
    fn a_dropped_canvas_closes_its_groups_and_the_document() {
        let out = drawn(|root| {
            root.draw(&GroupMark::Open(Group::class("x"))).unwrap();
        });
        assert!(out.ends_with("<g class=\"x\"></g></svg>\n"), "{out}");
    }

    #[test]
    fn text_is_escaped_and_control_characters_dropped() {
        let out = drawn(|root| {
            root.draw(&Text::new(
                "<b>\u{7}&",
                (3, 4),
                ("sans-serif", 12.4).into_font().color(&BLACK),
            ))
            .unwrap();
        });
        assert!(out.contains(">\n&lt;b&gt;&amp;\n</text>"), "{out}");
        assert!(out.contains("font-size=\"10\""), "{out}");
    }
}
