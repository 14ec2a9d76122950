//! The gateway's listening addresses ("faces"): the top-level `listen`, and one more for each
//! address a `[[line]]` names in its own `listen`.
//!
//! Why: a Modbus TCP request names its slave by a one-byte unit id, so one address reaches at
//! most 255 slaves, and mbusd serves one line per process and TCP port. A line with its own
//! address is reached there (mbusd's arrangement, one port per line, in one process), and its
//! unit ids need to be unique only among the lines on that address; lines naming the same
//! address share it. So 1,000 lines fit in one process. Every face answers the
//! diagnostic unit; a unit no line of the face serves is 0AH there, even if a line on another
//! face serves it (the client asked this address).
//!
//! The faces share the lines, their queues and the counters. Client ids (the queue's fair
//! order and the per-client counters key on them) carry the face's number in their top 16
//! bits, as each TCP server numbers its connections from 1.

use super::config::Gateway;
use super::counters::Stats;
use super::router::{LineHandle, Router};
use crate::Error;
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Handler, Peer, Server, ServerConfig, Units};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};

/// Bits of a client id left for the TCP server's own connection number.
const CONNECTION_BITS: u32 = 48;

/// One listening address and the lines (indices in file order) reached there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Face {
    /// The address as configured.
    pub listen: String,
    /// Its lines.
    pub lines: Vec<usize>,
}

/// The faces of `gw`: the top-level `listen` first (even with no line of its own: it still
/// answers the diagnostic unit and 0AH), then each line address in the order it first appears.
pub fn faces(gw: &Gateway) -> Vec<Face> {
    let mut faces = vec![Face {
        listen: gw.listen.clone(),
        lines: Vec::new(),
    }];
    let mut at = std::collections::HashMap::new();
    for (i, l) in gw.lines.iter().enumerate() {
        let face = match &l.listen {
            None => 0,
            Some(addr) => *at.entry(addr.clone()).or_insert_with(|| {
                faces.push(Face {
                    listen: addr.clone(),
                    lines: Vec::new(),
                });
                faces.len() - 1
            }),
        };
        faces[face].lines.push(i);
    }
    faces
}

/// A face's router, numbering its clients apart from the other faces'.
pub struct FaceHandler {
    face: u64,
    router: Router,
}

impl FaceHandler {
    /// The peer as the router sees it: the face's number in the id's top bits.
    fn peer(&self, peer: &Peer) -> Peer {
        Peer {
            id: self.face << CONNECTION_BITS | peer.id,
            addr: peer.addr,
        }
    }
}

impl Handler for FaceHandler {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        self.router.answer(request).await
    }

    async fn answer_from(&self, peer: &Peer, request: TcpAdu) -> Option<TcpAdu> {
        self.router.answer_from(&self.peer(peer), request).await
    }

    fn connected(&self, peer: &Peer) {
        self.router.connected(&self.peer(peer));
    }

    fn disconnected(&self, peer: &Peer) {
        self.router.disconnected(&self.peer(peer));
    }
}

/// The router of `face`, numbered `n` among the faces (its clients' ids carry it).
pub fn handler(
    gw: &Gateway,
    n: u64,
    face: &Face,
    lines: Arc<[LineHandle]>,
    stats: &Arc<Mutex<Stats>>,
) -> FaceHandler {
    let mut routes = [None; 256];
    for &i in &face.lines {
        for &u in &gw.lines[i].units {
            routes[u as usize] = Some(i);
        }
    }
    let router = Router {
        routes,
        lines,
        broadcast_lines: face
            .lines
            .iter()
            .copied()
            .filter(|&i| gw.lines[i].broadcast)
            .collect(),
        diagnostic_unit: gw.diagnostic_unit,
        reply_on_broadcast: gw.reply_on_broadcast,
        stats: Arc::clone(stats),
    };
    FaceHandler { face: n, router }
}

/// A bound face: where it listens, its lines, and its server (not yet running).
pub struct Bound {
    /// The address listened on.
    pub addr: SocketAddr,
    /// The face's lines.
    pub lines: Vec<usize>,
    /// The server.
    pub server: Server<FaceHandler>,
}

/// Listen on every face of `gw`; `lines` are the open lines in file order.
pub async fn bind(
    gw: &Gateway,
    lines: Arc<[LineHandle]>,
    stats: &Arc<Mutex<Stats>>,
) -> Result<Vec<Bound>, Error> {
    let mut bound = Vec::new();
    for (n, face) in faces(gw).into_iter().enumerate() {
        let config = ServerConfig {
            max_connections: gw.max_connections,
            units: Units::all(),
            idle_timeout: gw.idle_timeout,
        };
        let handler = handler(gw, n as u64, &face, Arc::clone(&lines), stats);
        let server = Server::with_handler(&face.listen, config, handler)
            .await
            .map_err(|e| Error::new(format!("cannot listen on {}: {e}", face.listen)))?;
        bound.push(Bound {
            addr: server.local_addr()?,
            lines: face.lines,
            server,
        });
    }
    Ok(bound)
}

/// Faces listed by address in the text of the "listening" line; more are counted only.
const LISTED_FACES: usize = 8;

/// The "listening" line: the top-level address and the line count, then the other addresses.
pub fn listening_text(gw: &Gateway, faces: &[Bound]) -> String {
    let mut text = format!(
        "gateway listening on {}, {} line(s)",
        faces[0].addr,
        gw.lines.len()
    );
    for f in faces.iter().skip(1).take(LISTED_FACES) {
        let names: Vec<_> = f.lines.iter().map(|&i| gw.lines[i].name.as_str()).collect();
        text += &format!("; {}: {}", f.addr, names.join(", "));
    }
    if faces.len() > LISTED_FACES + 1 {
        text += &format!("; {} more address(es)", faces.len() - LISTED_FACES - 1);
    }
    text
}

/// The "listening" event: `addr` (the top-level face) and every line's name as before, and
/// `listeners`, every face's address with its lines' names (the top-level face first).
pub fn listening_json(gw: &Gateway, faces: &[Bound]) -> serde_json::Value {
    let names = |lines: &[usize]| -> Vec<&str> {
        lines.iter().map(|&i| gw.lines[i].name.as_str()).collect()
    };
    let listeners: Vec<_> = faces
        .iter()
        .map(|f| serde_json::json!({"addr": f.addr.to_string(), "lines": names(&f.lines)}))
        .collect();
    serde_json::json!({"event": "listening", "addr": faces[0].addr.to_string(),
        "lines": gw.lines.iter().map(|l| &l.name).collect::<Vec<_>>(),
        "listeners": listeners})
}

/// Serve every face until one server ends (its error), or forever.
pub async fn run(faces: Vec<Bound>) -> std::io::Result<()> {
    let mut servers = tokio::task::JoinSet::new();
    for f in faces {
        servers.spawn(f.server.run());
    }
    match servers.join_next().await {
        Some(Ok(ended)) => ended,
        Some(Err(e)) => Err(std::io::Error::other(e)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::check as gateway;

    /// Units 1 and 2 on the top-level address and again on 127.0.0.1:5021.
    const TWO_FACES: &str = r#"
        listen = "127.0.0.1:5020"
        [[line]]
        device = "a"
        units = "1"
        [[line]]
        device = "b"
        units = "1"
        listen = "127.0.0.1:5021"
        [[line]]
        device = "c"
        units = "2"
        [[line]]
        device = "d"
        units = "2"
        listen = "127.0.0.1:5021"
        "#;

    #[test]
    fn lines_with_their_own_address_get_their_own_face() {
        // A line naming the top-level address is on the top face, where unit 1 is taken.
        let e = gateway(&format!(
            "{TWO_FACES}[[line]]\ndevice = \"e\"\nunits = \"1\"\nlisten = \"127.0.0.1:5020\"\n"
        ))
        .unwrap_err();
        assert!(e.contains("line 5 (line5): units = 1"), "{e}");
        let g = gateway(TWO_FACES).unwrap();
        let f = faces(&g);
        assert_eq!(
            f,
            [
                Face {
                    listen: "127.0.0.1:5020".into(),
                    lines: vec![0, 2]
                },
                Face {
                    listen: "127.0.0.1:5021".into(),
                    lines: vec![1, 3]
                },
            ]
        );
    }

    #[test]
    fn the_top_face_exists_without_lines_of_its_own() {
        let g =
            gateway("[[line]]\ndevice = \"a\"\nunits = \"1\"\nlisten = \"127.0.0.1:7\"\n").unwrap();
        let f = faces(&g);
        assert_eq!(f.len(), 2);
        assert!(f[0].lines.is_empty());
        assert_eq!(f[1].lines, [0]);
    }

    #[test]
    fn client_ids_of_two_faces_differ() {
        let router = |face| FaceHandler {
            face,
            router: Router {
                routes: [None; 256],
                lines: Arc::new([]),
                broadcast_lines: vec![],
                diagnostic_unit: None,
                reply_on_broadcast: false,
                stats: Arc::new(Mutex::new(Stats::new(0))),
            },
        };
        let peer = Peer {
            id: 1,
            addr: "127.0.0.1:9".parse().unwrap(),
        };
        assert_eq!(router(0).peer(&peer).id, 1);
        assert_eq!(router(1).peer(&peer).id, (1 << 48) | 1);
    }
}
