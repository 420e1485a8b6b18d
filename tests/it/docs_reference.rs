//! Reference pages generated from the code stay equal to it: the effect catalogue table in
//! docs/diagnosis.md is `model::catalogue::catalogue_markdown()`. Run with
//! `FLEETDYN_WRITE_DOCS=1` to rewrite the page's table from the code.

use fleetdyn::model::catalogue::catalogue_markdown;

const BEGIN: &str = "<!-- catalogue:begin (generated from the code: a test checks it) -->\n";
const END: &str = "<!-- catalogue:end -->";

#[test]
fn the_catalogue_table_in_the_docs_is_the_codes() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/diagnosis.md");
    let page = std::fs::read_to_string(path).unwrap();
    let a = page.find(BEGIN).expect("begin marker") + BEGIN.len();
    let b = page.find(END).expect("end marker");
    let table = catalogue_markdown();
    if std::env::var_os("FLEETDYN_WRITE_DOCS").is_some() {
        let new = format!("{}{}{}", &page[..a], table, &page[b..]);
        std::fs::write(path, new).unwrap();
        return;
    }
    assert_eq!(
        &page[a..b],
        table,
        "docs/diagnosis.md's catalogue table differs from the code; rewrite it with \
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
