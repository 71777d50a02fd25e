//! Generates the statement parser from `grammar/grm.lalrpop` into OUT_DIR.
fn main() {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR for build scripts");
    println!("cargo:rerun-if-changed=../../grammar/grm.lalrpop");
    lalrpop::Configuration::new()
        .set_in_dir("../../grammar")
        .set_out_dir(out)
        .process()
        .expect("grammar/grm.lalrpop must be a valid LALR(1) grammar");
}
