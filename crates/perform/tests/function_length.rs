//! No function in `crates/perform/src` is longer than a screen: 150 lines at most
//! (testkit's scanner, [`testkit::lines`]).

#[test]
fn no_function_in_the_crate_is_over_150_lines() {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    testkit::lines::assert_short(&src);
}
