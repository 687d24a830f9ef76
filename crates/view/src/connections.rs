//! The server's open connections, and room made when they are too many. Each connection has its
//! own thread; when one arrives while [`MAX_CONNECTIONS`] are open, one that is *waiting for its
//! client* (blocked reading a request line, headers or body that have not come) is closed to make
//! room: of the peer (IP address) with the most such connections, the one accepted first. A
//! connection answering (computing or sending its reply) is never closed for room. So a client
//! holding dozens of half-sent requests loses its oldest ones, one per new connection, and a real
//! request is answered at once; on loopback every local process is 127.0.0.1, one peer, and the
//! rule is "oldest waiting first", which a request that sends its head at once survives unless
//! some [`MAX_CONNECTIONS`] others arrive in the moment before its head does.

use std::collections::BTreeMap;
use std::net::{IpAddr, Shutdown, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// Connections open at once (each on its own thread) before waiting ones are closed for room;
/// when every open connection is answering, the next one waits, unread, until one ends.
pub const MAX_CONNECTIONS: usize = 64;

/// What a connection's thread is doing, as the accepting thread sees it.
#[derive(Debug, Default)]
pub struct Status {
    waiting: AtomicBool,
    closed_for_room: AtomicBool,
}

impl Status {
    /// Marks the thread as blocked reading from its client (`true`) or not (`false`).
    pub fn set_waiting(&self, waiting: bool) {
        self.waiting.store(waiting, Ordering::SeqCst);
    }

    /// Whether the connection was closed to make room for another.
    pub fn closed_for_room(&self) -> bool {
        self.closed_for_room.load(Ordering::SeqCst)
    }
}

/// One open connection in the table.
struct Open {
    id: u64,
    peer: IpAddr,
    /// A handle on the socket, to close its reading side.
    stream: TcpStream,
    status: Arc<Status>,
}

/// The open connections.
#[derive(Default)]
pub struct Connections {
    open: Mutex<Vec<Open>>,
    next_id: AtomicU64,
}

impl Connections {
    /// Enters a connection from `peer`; it leaves the table when the [`Ticket`] drops (or when
    /// closed for room). Fails when the socket cannot be shared (the caller drops it).
    pub fn admit(self: &Arc<Self>, stream: &TcpStream, peer: IpAddr) -> std::io::Result<Ticket> {
        let id = self.next_id.fetch_add(1, Ordering::SeqCst);
        let status = Arc::new(Status::default());
        let open = Open { id, peer, stream: stream.try_clone()?, status: Arc::clone(&status) };
        self.lock().push(open);
        Ok(Ticket { table: Arc::clone(self), id, status })
    }

    /// Connections in the table.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Whether the table is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Closes the reading side of one waiting connection other than `keep` (see the module
    /// doc for which) and takes it out of the table; `false` when none is waiting.
    pub fn close_one_waiting(&self, keep: u64) -> bool {
        let mut open = self.lock();
        let waiting = open
            .iter()
            .filter(|o| o.id != keep && o.status.waiting.load(Ordering::SeqCst))
            .map(|o| (o.id, o.peer));
        let Some(id) = oldest_of_busiest_peer(waiting) else {
            return false;
        };
        let Some(at) = open.iter().position(|o| o.id == id) else {
            return false;
        };
        let victim = open.swap_remove(at);
        victim.status.closed_for_room.store(true, Ordering::SeqCst);
        // Wakes the blocked read with end-of-stream; the thread answers 503 or closes quietly.
        let _ = victim.stream.shutdown(Shutdown::Read);
        true
    }

    fn lock(&self) -> MutexGuard<'_, Vec<Open>> {
        // A panic while holding the lock leaves a plain list behind: still usable.
        self.open.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

/// Of `(id, peer)` pairs (ids in order of arrival), the first-accepted of the peer with the most;
/// between peers with as many, the one whose first is older.
pub fn oldest_of_busiest_peer(waiting: impl Iterator<Item = (u64, IpAddr)>) -> Option<u64> {
    let mut by_peer: BTreeMap<IpAddr, (usize, u64)> = BTreeMap::new();
    for (id, peer) in waiting {
        let entry = by_peer.entry(peer).or_insert((0, id));
        entry.0 += 1;
        entry.1 = entry.1.min(id);
    }
    by_peer.into_values().max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1))).map(|(_, oldest)| oldest)
}

/// A connection's place in the [`Connections`] table, given back on drop.
pub struct Ticket {
    table: Arc<Connections>,
    id: u64,
    status: Arc<Status>,
}

impl Ticket {
    /// The connection's number, in order of arrival.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// What the connection's thread reports and the table decides.
    pub fn status(&self) -> &Status {
        &self.status
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        let mut open = self.table.lock();
        if let Some(at) = open.iter().position(|o| o.id == self.id) {
            open.swap_remove(at);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::{Ipv4Addr, TcpListener};

    #[test]
    fn the_busiest_peer_loses_its_oldest_waiting_connection() {
        let a = IpAddr::V4(Ipv4Addr::new(10, 0, 0, 1));
        let b = IpAddr::V4(Ipv4Addr::new(10, 0, 0, 2));
        assert_eq!(oldest_of_busiest_peer(std::iter::empty()), None);
        assert_eq!(oldest_of_busiest_peer([(4, a), (2, a), (7, a)].into_iter()), Some(2));
        // b holds three, a two older ones: b's oldest goes
        assert_eq!(oldest_of_busiest_peer([(1, a), (2, a), (5, b), (6, b), (9, b)].into_iter()), Some(5));
        // as many each: the older of the two peers' oldest
        assert_eq!(oldest_of_busiest_peer([(8, b), (3, a), (9, b), (4, a)].into_iter()), Some(3));
    }

    #[test]
    fn only_waiting_connections_are_closed_for_room_and_their_read_ends() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        let table = Arc::new(Connections::default());
        let clients: Vec<TcpStream> = (0..3).map(|_| TcpStream::connect(addr).expect("connect")).collect();
        let mut tickets = Vec::new();
        let mut servers = Vec::new();
        for _ in &clients {
            let (stream, peer) = listener.accept().expect("accept");
            tickets.push(table.admit(&stream, peer.ip()).expect("admit"));
            servers.push(stream);
        }
        assert_eq!(table.len(), 3);
        // none waiting: nothing to close
        assert!(!table.close_one_waiting(u64::MAX));
        tickets[1].status().set_waiting(true);
        tickets[2].status().set_waiting(true);
        assert!(table.close_one_waiting(tickets[2].id()));
        assert_eq!(table.len(), 2, "the waiting connection accepted first went");
        assert!(tickets[1].status().closed_for_room() && !tickets[0].status().closed_for_room());
        servers[1].set_read_timeout(Some(std::time::Duration::from_secs(5))).expect("timeout");
        assert_eq!(servers[1].read(&mut [0u8; 8]).expect("end of stream, not a timeout"), 0);
        // the one kept is not closed even when it is the only one waiting
        assert!(!table.close_one_waiting(tickets[2].id()));
        drop(tickets);
        assert!(table.is_empty(), "tickets give their place back");
    }
}
