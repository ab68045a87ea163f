# Sourced by the test scripts (bash): the one package and feature selection of every cargo build
# they make. Cargo resolves the dependencies' features for the packages a build selects, so
# `cargo build -p rmd-cli`, `cargo build --example pd_hold` and `cargo test -p rmd-bus
# --features kernel-tests` each compile a tree of their own (nix, socketcan, the loop, ... once
# per selection). With one selection, every script's build after the first finds everything
# built: the whole workspace, its examples (so its dev-dependencies), with the kernel tests'
# features on (they only add the two kernel test binaries, which the Rust test run leaves to
# tests/vcan/run.sh: .config/nextest.toml's default filter).
#
#   cargo build "${RMD_WORKSPACE[@]}" --bins --examples    the binaries and examples
#   cargo test "${RMD_WORKSPACE[@]}" --no-run              the test binaries (the same tree)
RMD_WORKSPACE=(--workspace --features rmd-bus/kernel-tests,rmd-cli/kernel-tests)
