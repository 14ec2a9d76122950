//! The examples run as they are.

#[path = "../examples/embed.rs"]
mod embed;

#[test]
fn the_embedding_example_starts_a_gateway_and_is_answered() {
    embed::main().unwrap();
}
