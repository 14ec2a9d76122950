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

use super::backend::Backend;
use super::config::Config;
use super::counters::Stats;
use super::router::Router;
use crate::Error;
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Handler, Peer, Server, ServerConfig, Units};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, RwLock};

/// Bits of a client id left for the TCP server's own connection number.
pub const CONNECTION_BITS: u32 = 48;

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
pub fn faces(gw: &Config) -> Vec<Face> {
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

/// A face's router, numbering its clients apart from the other faces'. Its clones share the
/// router, which a reload replaces for all of them at once.
#[derive(Clone)]
pub struct FaceHandler {
    face: u64,
    router: Arc<RwLock<Arc<Router>>>,
}

impl FaceHandler {
    /// Face number `face` routing by `router`.
    pub fn new(face: usize, router: Router) -> Self {
        FaceHandler {
            face: face as u64,
            router: Arc::new(RwLock::new(Arc::new(router))),
        }
    }

    /// Route by `router` from now on (requests already routed finish by the old one).
    pub fn replace(&self, router: Router) {
        *self.router.write().unwrap_or_else(|p| p.into_inner()) = Arc::new(router);
    }

    /// The router now.
    fn current(&self) -> Arc<Router> {
        Arc::clone(&self.router.read().unwrap_or_else(|p| p.into_inner()))
    }

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
        self.current().answer(request).await
    }

    async fn answer_from(&self, peer: &Peer, request: TcpAdu) -> Option<TcpAdu> {
        self.current().answer_from(&self.peer(peer), request).await
    }

    fn connected(&self, peer: &Peer) {
        self.current().connected(&self.peer(peer));
    }

    fn disconnected(&self, peer: &Peer) {
        self.current().disconnected(&self.peer(peer));
    }
}

/// A bound face: where it listens, its lines, and its server (not yet running).
pub struct Bound {
    /// The address listened on.
    pub addr: SocketAddr,
    /// The face's lines.
    pub lines: Vec<usize>,
    /// The server.
    pub server: Server<FaceHandler>,
    /// A copy of the server's handler: the same routes and counters.
    pub handler: FaceHandler,
}

/// The router of each face of `gw`: line `i` of the configuration is `lines[slots[i]]`.
pub fn routers(
    gw: &Config,
    slots: &[usize],
    lines: &Arc<[Arc<dyn Backend>]>,
    stats: &Arc<Mutex<Stats>>,
) -> Vec<Router> {
    faces(gw)
        .into_iter()
        .map(|face| {
            let mut routes = [None; 256];
            for &i in &face.lines {
                let line = &gw.lines[i];
                for &u in &line.units {
                    let address = line.unit_map.get(&u).copied().unwrap_or(u);
                    routes[u as usize] = Some((slots[i], address));
                }
            }
            Router {
                routes,
                lines: Arc::clone(lines),
                broadcast_lines: face
                    .lines
                    .iter()
                    .filter(|&&i| gw.lines[i].broadcast)
                    .map(|&i| slots[i])
                    .collect(),
                diagnostic_unit: gw.diagnostic_unit,
                reply_on_broadcast: gw.reply_on_broadcast,
                stats: Arc::clone(stats),
            }
        })
        .collect()
}

/// Listen on every face of `gw`; `lines` are the open lines in file order.
pub async fn bind(
    gw: &Config,
    lines: Arc<[Arc<dyn Backend>]>,
    stats: &Arc<Mutex<Stats>>,
) -> Result<Vec<Bound>, Error> {
    let slots: Vec<usize> = (0..gw.lines.len()).collect();
    let mut bound = Vec::new();
    let routers = routers(gw, &slots, &lines, stats);
    for ((n, face), router) in faces(gw).into_iter().enumerate().zip(routers) {
        let config = ServerConfig {
            max_connections: gw.max_connections,
            units: Units::all(),
            idle_timeout: gw.idle_timeout,
        };
        let handler = FaceHandler::new(n, router);
        let server = Server::with_handler(&face.listen, config, handler.clone())
            .await
            .map_err(|e| Error::new(format!("cannot listen on {}: {e}", face.listen)))?;
        bound.push(Bound {
            addr: server.local_addr()?,
            lines: face.lines,
            server,
            handler,
        });
    }
    Ok(bound)
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
        let router = |face| {
            FaceHandler::new(
                face,
                Router {
                    routes: [None; 256],
                    lines: Arc::new([]),
                    broadcast_lines: vec![],
                    diagnostic_unit: None,
                    reply_on_broadcast: false,
                    stats: Arc::new(Mutex::new(Stats::new(0))),
                },
            )
        };
        let peer = Peer {
            id: 1,
            addr: "127.0.0.1:9".parse().unwrap(),
        };
        assert_eq!(router(0).peer(&peer).id, 1);
        assert_eq!(router(1).peer(&peer).id, (1 << 48) | 1);
    }
}
