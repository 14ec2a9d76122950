//! `si-pace PTY_1 PTY_2 BAUD [BITS_PER_CHAR]`: a virtual wire between two pseudo-terminals (the
//! far ends of two socat pairs). A pseudo-terminal ignores the baud rate and passes a frame as
//! fast as the kernel copies it; through this relay every byte arrives when its last bit
//! would have on a line of BITS_PER_CHAR bits (10: 8N1, the default) at BAUD bit/s, in both
//! directions, one character time after the byte before it or after it was written
//! ([`si_testkit::relay`], [`Adapter::wire`]). Prints `ready` once both ends are open; runs
//! until a pseudo-terminal closes. For the gateway benchmarks (`benches/gateway/vs_mbusd.sh`
//! with `PACE=1`); a Rust relay rather than a Python one, so that the relay's own stalls do not
//! put silence inside frames.

use si_testkit::relay::{usb_relay, Adapter};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: si-pace PTY_1 PTY_2 BAUD [BITS_PER_CHAR (10)]";
    let (Some(a), Some(b), Some(baud)) = (args.first(), args.get(1), args.get(2)) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let number = |name: &str, text: &str| -> u32 {
        text.parse().ok().filter(|&n| n > 0).unwrap_or_else(|| {
            eprintln!("si-pace: {name} {text:?} is not a positive whole number; {usage}");
            std::process::exit(2)
        })
    };
    let baud = number("BAUD", baud);
    let bits = args.get(3).map_or(10, |bits| number("BITS_PER_CHAR", bits));
    let relay = usb_relay(a, b, Adapter::wire(baud, bits));
    println!("ready");
    relay.join();
}
