//! Reference pages generated from the code stay equal to it: the effect catalogue table in
//! docs/diagnosis/catalogue.md is `model::catalogue_table::catalogue_markdown()`, between the markers
//! of section `catalogue` (`fleetdyn::schema::reference`). Run with `FLEETDYN_WRITE_DOCS=1` to
//! rewrite the page's table from the code.

use fleetdyn::model::catalogue_table::catalogue_markdown;
use fleetdyn::schema::reference::{section, splice};

const PAGE: &str = "docs/diagnosis/catalogue.md";

#[test]
fn the_catalogue_table_in_the_docs_is_the_codes() {
    let path = format!("{}/{PAGE}", env!("CARGO_MANIFEST_DIR"));
    let page = std::fs::read_to_string(&path).unwrap();
    let table = catalogue_markdown();
    let old = section(&page, "catalogue").expect("one pair of catalogue markers");
    if std::env::var_os("FLEETDYN_WRITE_DOCS").is_some() {
        if old != table {
            std::fs::write(&path, splice(&page, "catalogue", &table).unwrap()).unwrap();
        }
        return;
    }
    assert_eq!(
        old, table,
        "{PAGE}'s catalogue table differs from the code; rewrite it with \
         FLEETDYN_WRITE_DOCS=1 cargo test --release --test it docs_reference"
    );
    // every catalogue id appears once in the table
    for row in fleetdyn::model::catalogue::CATALOGUE.iter() {
        assert_eq!(
            table.matches(&format!("| `{}` |", row.id)).count(),
            1,
            "{}",
            row.id
        );
    }
}
