//! Tables: identified against truth with relative errors, efficiency, the
//! time and FRF routes side by side.

mod common;

use common::{parse, sel, text};

/// Parses "+0.123 %", "-12.3 %", "+3.21e-5 %" back to a fraction.
fn parse_percent(s: &str) -> f64 {
    let number = s
        .trim()
        .trim_end_matches('%')
        .trim()
        .trim_start_matches('+');
    number
        .parse::<f64>()
        .unwrap_or_else(|_| panic!("not a percentage: {s:?}"))
        / 100.0
}

#[test]
fn every_comparison_row_shows_its_relative_error() {
    let report = common::report();
    let doc = parse(&reports::render(&report).unwrap());
    let mut rows_checked = 0;
    for (i, study) in report.studies.iter().enumerate() {
        let rep = study.representative.as_ref().unwrap();
        let tables: Vec<_> = doc
            .select(&sel(&format!("article#study-{} table.comparison", i + 1)))
            .collect();
        assert_eq!(tables.len(), rep.tables.len());
        for (table, data) in tables.iter().zip(&rep.tables) {
            let caption = table.select(&sel("caption")).map(text).next().unwrap();
            assert!(caption.starts_with(&data.title), "{caption:?}");
            assert!(
                caption.contains(&format!("[{}]", data.unit)),
                "{caption:?} has the unit"
            );
            let rows: Vec<_> = table.select(&sel("tbody tr")).collect();
            assert_eq!(rows.len(), data.rows.len());
            for (tr, row) in rows.iter().zip(&data.rows) {
                assert_eq!(tr.select(&sel("th")).map(text).next().unwrap(), row.label);
                let cells: Vec<String> = tr.select(&sel("td")).map(text).collect();
                assert_eq!(cells.len(), 3);
                // Values to 5 significant digits.
                let truth: f64 = cells[0].parse().unwrap();
                let identified: f64 = cells[1].parse().unwrap();
                assert!((truth - row.truth).abs() <= 5e-5 * row.truth.abs());
                assert!((identified - row.identified).abs() <= 5e-5 * row.identified.abs());
                let td = tr.select(&sel("td[data-rel-error]")).next().unwrap();
                if row.truth == 0.0 {
                    assert_eq!(td.value().attr("data-rel-error"), Some("none"));
                    assert!(cells[2].starts_with('—'), "{:?}", cells[2]);
                    rows_checked += 1;
                    continue;
                }
                let want = (row.identified - row.truth) / row.truth.abs();
                let exact: f64 = td.value().attr("data-rel-error").unwrap().parse().unwrap();
                assert!(
                    (exact - want).abs() <= 1e-12 * want.abs().max(1e-300),
                    "{exact} vs {want}"
                );
                // Shown with 3 significant digits and its sign.
                let shown = parse_percent(&cells[2]);
                assert!(
                    (shown - want).abs() <= 5e-3 * want.abs(),
                    "{}: shown {:?}, want {want}",
                    row.label,
                    cells[2]
                );
                assert_eq!(cells[2].starts_with('-'), want < 0.0, "{:?}", cells[2]);
                rows_checked += 1;
            }
        }
    }
    assert!(rows_checked > 40, "{rows_checked} rows");
}

#[test]
fn large_errors_stand_out() {
    let report = common::report();
    let doc = parse(&reports::render(&report).unwrap());
    // The MKR damping table of the synthetic data is off by two orders of
    // magnitude, as in the paper; those cells are flagged.
    let flagged = doc
        .select(&sel("article#study-1 table.comparison td.bad"))
        .map(text)
        .collect::<Vec<_>>();
    assert!(flagged.iter().any(|t| t == "+9600 %"), "{flagged:?}");
}

#[test]
fn efficiency_table_pivots_noise_levels_into_columns() {
    let report = common::report();
    let doc = parse(&reports::render(&report).unwrap());
    let eff = &report.studies[0].accuracy.efficiency;
    let table = doc
        .select(&sel("article#study-1 table.efficiency"))
        .next()
        .unwrap();
    let header: Vec<String> = table.select(&sel("thead th")).map(text).collect();
    let mut levels: Vec<f64> = eff.iter().map(|e| e.noise_level).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    assert_eq!(header.len(), 2 + levels.len());
    assert_eq!(header[2], format!("{} %", levels[0] * 100.0));
    for tr in table.select(&sel("tbody tr")) {
        let quantity = tr.select(&sel("th")).map(text).next().unwrap();
        let cells: Vec<String> = tr.select(&sel("td")).map(text).collect();
        let estimator = &cells[0];
        for (l, cell) in levels.iter().zip(&cells[1..]) {
            let e = eff
                .iter()
                .find(|e| {
                    e.quantity == quantity && &e.estimator == estimator && e.noise_level == *l
                })
                .unwrap();
            let shown: f64 = cell.parse().unwrap();
            assert!((shown - e.efficiency).abs() <= 5e-3 * e.efficiency);
        }
    }
}

#[test]
fn route_table_shows_both_routes_per_level() {
    let mut report = common::report();
    let errors = |trials, median, rms, efficiency| reports::RouteErrors {
        trials,
        median,
        rms,
        efficiency,
        median_se: None,
        efficiency_se: None,
    };
    report.studies[0].accuracy.routes = vec![
        reports::RouteRow {
            noise_level: 0.0,
            quantity: "mass matrix".into(),
            time: errors(4, 2e-6, 3e-6, f64::NAN),
            frf: errors(4, 4e-5, 5e-5, f64::NAN),
        },
        reports::RouteRow {
            noise_level: 0.01,
            quantity: "mass matrix".into(),
            time: errors(20, 1e-3, 2e-3, 0.5),
            frf: errors(19, 2e-3, 4e-3, 0.25),
        },
    ];
    let doc = parse(&reports::render(&report).unwrap());
    let table = doc
        .select(&sel("article#study-1 table.routes"))
        .next()
        .expect("the route table");
    let header: Vec<String> = table.select(&sel("thead th")).map(text).collect();
    // Noise, quantity, 4 columns per route, the MSE ratio.
    assert_eq!(header.len(), 2 + 2 * 4 + 1, "{header:?}");
    let rows: Vec<Vec<String>> = table
        .select(&sel("tbody tr"))
        .map(|tr| tr.select(&sel("th, td")).map(text).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1][0], "1 %");
    assert_eq!(rows[1][1], "mass matrix");
    let numbers = |cells: &[String]| -> Vec<f64> {
        cells.iter().map(|c| c.parse::<f64>().unwrap()).collect()
    };
    // Shown to 3 significant digits, exact for these values; the last
    // column is the MSE ratio (4e-3 / 2e-3)^2 = 4.
    assert_eq!(
        numbers(&rows[1][2..]),
        [20.0, 1e-3, 2e-3, 0.5, 19.0, 2e-3, 4e-3, 0.25, 4.0]
    );
    // No bound at zero noise: the efficiency cells say so.
    assert_eq!(rows[0][5], rows[0][9]);
    assert!(rows[0][5].parse::<f64>().is_err(), "{:?}", rows[0]);
    // Other studies ran one route: no table.
    assert!(
        doc.select(&sel("article#study-2 table.routes"))
            .next()
            .is_none()
    );
}

/// A style rule: enclosing at-rule (or ""), selector, declarations as
/// (property, value).
type Rule = (String, String, Vec<(String, String)>);

/// The rules of the document's style sheet.
fn style_rules(doc: &scraper::Html) -> Vec<Rule> {
    let css: String = doc.select(&sel("head > style")).map(text).collect();
    let mut rules = vec![];
    let mut context = String::new();
    let mut depth = 0;
    let mut start = 0;
    let mut selector = String::new();
    for (i, c) in css.char_indices() {
        match c {
            '{' => {
                let head = css[start..i].trim().to_string();
                if head.starts_with('@') {
                    context = head;
                } else {
                    selector = head;
                }
                depth += 1;
                start = i + 1;
            }
            '}' => {
                if !selector.is_empty() {
                    let declarations = css[start..i]
                        .split(';')
                        .filter_map(|d| d.split_once(':'))
                        .map(|(p, v)| (p.trim().to_string(), v.trim().to_string()))
                        .collect();
                    let at = if depth > 1 {
                        context.clone()
                    } else {
                        String::new()
                    };
                    rules.push((at, std::mem::take(&mut selector), declarations));
                }
                depth -= 1;
                if depth == 0 {
                    context.clear();
                }
                start = i + 1;
            }
            _ => {}
        }
    }
    rules
}

/// Guards the layout of the identified-against-truth tables. They used to
/// sit in a grid whose tracks had a fixed minimum (330 px) and came out
/// 361 px wide in a 1400-px window, narrower than a four-column table of
/// 5-significant-digit numbers (370-380 px): the relative-error column hid
/// behind a horizontal scrollbar. Now the tables flow in a wrapping flex
/// row and each table's box starts from its content's width (flex basis
/// `auto`, i.e. the table's max-content width; number cells do not wrap),
/// so a table that does not fit beside the others moves to the next line
/// instead of being squeezed. A column can only be cut off when one table
/// is wider than the whole page column, and then the box shrinks to the
/// page and scrolls (`min-width: 0`, `max-width: 100%`). This fails if the
/// container goes back to fixed tracks, if the boxes get a width or a basis
/// of their own, or if the tables leave the container the rules select.
#[test]
fn comparison_tables_take_the_width_their_columns_need() {
    let doc = parse(&reports::render(&common::report()).unwrap());
    // Structure: every comparison table is alone in a .table-wrap that is a
    // direct child of the .tables container.
    let mut tables = 0;
    for table in doc.select(&sel("table.comparison")) {
        let wrap = scraper::ElementRef::wrap(table.parent().unwrap()).unwrap();
        assert!(wrap.value().classes().any(|c| c == "table-wrap"));
        assert_eq!(common::child_elements(wrap).len(), 1);
        let container = scraper::ElementRef::wrap(wrap.parent().unwrap()).unwrap();
        assert!(container.value().classes().any(|c| c == "tables"));
        tables += 1;
    }
    assert!(tables >= 7, "{tables} comparison tables");

    let rules = style_rules(&doc);
    let declared = |selector: &str, property: &str| -> Vec<(String, String)> {
        rules
            .iter()
            .filter(|(_, s, _)| s.split(',').any(|s| s.trim() == selector))
            .flat_map(|(at, _, d)| {
                d.iter()
                    .filter(|(p, _)| p == property)
                    .map(move |(_, v)| (at.clone(), v.clone()))
            })
            .collect()
    };
    let top = |selector: &str, property: &str| -> Option<String> {
        declared(selector, property)
            .into_iter()
            .filter(|(at, _)| at.is_empty())
            .map(|(_, v)| v)
            .next_back()
    };
    assert_eq!(top(".tables", "display").as_deref(), Some("flex"));
    assert_eq!(top(".tables", "flex-wrap").as_deref(), Some("wrap"));
    assert_eq!(declared(".tables", "grid-template-columns"), vec![]);
    for property in ["display", "flex-wrap"] {
        for (at, v) in declared(".tables", property) {
            assert!(at.is_empty(), "{at} overrides .tables {property}: {v}");
        }
    }
    let item = ".tables > .table-wrap";
    let flex = top(item, "flex").expect("the boxes' flex");
    let parts: Vec<&str> = flex.split_whitespace().collect();
    assert_eq!(parts.get(2), Some(&"auto"), "flex basis of {flex:?}");
    assert_eq!(parts.first(), Some(&"0"), "no growing: {flex:?}");
    assert_eq!(top(item, "min-width").as_deref(), Some("0"));
    assert_eq!(top(item, "max-width").as_deref(), Some("100%"));
    for property in ["width", "flex-basis", "min-width", "max-width", "flex"] {
        for (at, v) in declared(item, property) {
            assert!(at.is_empty(), "{at} sets {item} {property}: {v}");
        }
        for selector in [".table-wrap", "table.comparison", "table"] {
            for (at, v) in declared(selector, property) {
                assert!(
                    property == "max-width" && v == "none",
                    "{at} {selector} {property}: {v} would bound the tables' width"
                );
            }
        }
    }
    // Numbers stay on one line, so the content width is that of the
    // widest number of each column.
    assert_eq!(top("td.num", "white-space").as_deref(), Some("nowrap"));
}

#[test]
fn monte_carlo_errors_are_shown_beside_medians_and_efficiencies() {
    let mut report = common::report();
    let errors = |median_se, efficiency_se| reports::RouteErrors {
        trials: 20,
        median: 1e-3,
        rms: 2e-3,
        efficiency: 0.5,
        median_se,
        efficiency_se,
    };
    report.studies[0].accuracy.routes = vec![reports::RouteRow {
        noise_level: 0.01,
        quantity: "mass matrix".into(),
        time: errors(Some(1.234e-4), Some(0.0456)),
        frf: errors(None, Some(f64::NAN)),
    }];
    for e in &mut report.studies[0].accuracy.efficiency {
        e.se = Some(0.0123);
    }
    let doc = parse(&reports::render(&report).unwrap());
    let cells: Vec<String> = doc
        .select(&sel("article#study-1 table.routes tbody td"))
        .map(text)
        .collect();
    // Two significant digits of the error; none where it is missing or not
    // a number.
    assert_eq!(cells[1], "0.00100 ± 1.2e-4", "{cells:?}");
    assert_eq!(cells[3], "0.500 ± 0.046", "{cells:?}");
    assert_eq!(cells[5], "0.00100", "{cells:?}");
    assert_eq!(cells[7], "0.500", "{cells:?}");
    let eff: Vec<String> = doc
        .select(&sel("article#study-1 table.efficiency tbody td.num"))
        .map(text)
        .collect();
    assert!(!eff.is_empty());
    for c in &eff {
        assert!(c.ends_with(" ± 0.012"), "{c}");
    }
}
