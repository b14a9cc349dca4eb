//! Tables: identified against truth with relative errors, efficiency.

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
