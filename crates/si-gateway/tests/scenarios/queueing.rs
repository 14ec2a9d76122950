//! A line's bounded queue, in-process: a request beyond it is answered 06H at once and
//! counted busy; those in it wait their turn and time out (0BH) on a silent slave.

use crate::common::config;
use si_gateway::open::{Connect, Opening};
use si_gateway::{Gateway, Options};
use std::sync::{Arc, Mutex};

/// In virtual time: one line whose slave never answers, a queue of one, four requests at once.
#[tokio::test(start_paused = true)]
async fn a_request_beyond_the_queue_gets_06h_and_the_others_time_out() {
    let ends = Arc::new(Mutex::new(Vec::new()));
    let keep = Arc::clone(&ends);
    let silent: Connect = Arc::new(move |_line, _settings| {
        let (a, b) = tokio::io::duplex(1024);
        keep.lock().unwrap().push(b);
        Box::pin(async move { Ok(Box::new(a) as Box<dyn si_core::driver::Transport>) })
    });
    let text = "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"s\"\ndevice = \"x\"\nunits = \"1\"\n\
                queue = 1\nretries = 0\nresponse_timeout_ms = 50\npause_ms = 0\n\
                quiet_after_timeout_ms = 0\n";
    let options = Options {
        opening: Opening {
            connect: Some(silent),
            ..Opening::default()
        },
        ..Options::default()
    };
    let gateway = Gateway::start_with(config(text), options).await.unwrap();
    let h = gateway.handler();
    let ask = |t| {
        let h = h.clone();
        async move {
            h.call(crate::common::read(t, 1, 0))
                .await
                .unwrap()
                .unit_pdu()[2]
        }
    };
    let codes = tokio::join!(ask(1), ask(2), ask(3), ask(4));
    let codes = [codes.0, codes.1, codes.2, codes.3];
    let busy = codes.iter().filter(|&&c| c == 0x06).count();
    assert!(
        busy >= 2,
        "one request on the line, one queued, the rest busy: {codes:?}"
    );
    assert!(
        codes.iter().all(|&c| c == 0x06 || c == 0x0B),
        "busy or timed out: {codes:?}"
    );
    let s = gateway.stats();
    assert_eq!(s.lines[0].busy as usize, busy);
    assert_eq!(s.lines[0].timeouts as usize, 4 - busy);
}
