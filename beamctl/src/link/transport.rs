//! Where the bytes come from and go to: a serial port (`serialport`), a
//! TCP socket (QEMU's `-serial tcp:…`, a serial-to-network bridge) or a
//! file of captured bytes; and a reader thread that hands the bytes to the
//! caller's event loop.
//!
//! # End of stream
//! The reader thread ends with one [`StreamEnd`]:
//! * a file that ends is the end of the capture ([`StreamEnd::Eof`]);
//! * a TCP peer that closes the connection, or a serial device that hangs
//!   up (USB unplugged, the other end of a pty closed: `read` fails, or
//!   returns 0 bytes after the port said it was readable), is
//!   [`StreamEnd::Closed`] or [`StreamEnd::Failed`]: the device is gone.
//!
//! Serial ports are read with a 100 ms timeout, which is not an end: the
//! thread just reads again.

use std::fmt;
use std::fs::File;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a serial read waits before it tries again.
const SERIAL_READ_TIMEOUT: Duration = Duration::from_millis(100);
/// How long a TCP connection attempt may take.
const TCP_CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// Bytes per read.
const CHUNK: usize = 16 * 1024;

/// A byte stream to a device (or a capture of one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// A serial port: its path (`/dev/ttyACM0`, `COM3`) and baud rate
    /// (8N1, no flow control).
    Serial {
        /// The device path or name.
        path: String,
        /// Baud rate.
        baud: u32,
    },
    /// A TCP server, `HOST:PORT`.
    Tcp(String),
    /// A file of bytes captured from a device (read only).
    File(PathBuf),
}

impl Endpoint {
    /// True for a live device (serial or TCP), false for a capture file.
    pub fn is_live(&self) -> bool {
        !matches!(self, Self::File(_))
    }
}

impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Serial { path, baud } => write!(f, "serial port {path} ({baud} baud)"),
            Self::Tcp(addr) => write!(f, "TCP {addr}"),
            Self::File(p) => write!(f, "file {}", p.display()),
        }
    }
}

/// An open endpoint: a reader and, for live devices, a writer.
pub struct Connection {
    /// What was opened.
    pub endpoint: Endpoint,
    reader: Box<dyn Read + Send>,
    writer: Option<Box<dyn Write + Send>>,
}

impl fmt::Debug for Connection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Connection")
            .field("endpoint", &self.endpoint)
            .field("writable", &self.writer.is_some())
            .finish()
    }
}

/// Open `endpoint`. The error says what could not be opened and why.
pub fn open(endpoint: &Endpoint) -> Result<Connection, String> {
    let (reader, writer): (Box<dyn Read + Send>, Option<Box<dyn Write + Send>>) = match endpoint {
        Endpoint::Serial { path, baud } => {
            let port = serialport::new(path.as_str(), *baud)
                .timeout(SERIAL_READ_TIMEOUT)
                .open()
                .map_err(|e| format!("cannot open serial port {path}: {e}"))?;
            let writer = port
                .try_clone()
                .map_err(|e| format!("cannot open serial port {path}: {e}"))?;
            (Box::new(port), Some(Box::new(writer)))
        }
        Endpoint::Tcp(addr) => {
            let stream = connect(addr).map_err(|e| format!("cannot connect to {addr}: {e}"))?;
            // Commands are small and rare: send them at once.
            stream
                .set_nodelay(true)
                .map_err(|e| format!("cannot configure {addr}: {e}"))?;
            let writer = stream
                .try_clone()
                .map_err(|e| format!("cannot configure {addr}: {e}"))?;
            (Box::new(stream), Some(Box::new(writer)))
        }
        Endpoint::File(p) => {
            let f = File::open(p).map_err(|e| format!("cannot open {}: {e}", p.display()))?;
            (Box::new(f), None)
        }
    };
    Ok(Connection {
        endpoint: endpoint.clone(),
        reader,
        writer,
    })
}

fn connect(addr: &str) -> io::Result<TcpStream> {
    let mut last = io::Error::new(io::ErrorKind::NotFound, "no address");
    for a in addr.to_socket_addrs()? {
        match TcpStream::connect_timeout(&a, TCP_CONNECT_TIMEOUT) {
            Ok(s) => return Ok(s),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// What the reader thread reports.
#[derive(Debug)]
pub enum Incoming {
    /// Bytes read, and when.
    Bytes(Vec<u8>, Instant),
    /// The stream ended; nothing follows.
    End(StreamEnd),
}

/// Why a stream ended.
#[derive(Debug)]
pub enum StreamEnd {
    /// A capture file ended.
    Eof,
    /// A live device closed the stream (TCP peer closed; a serial port read
    /// 0 bytes).
    Closed,
    /// Reading failed (a serial device unplugged, a pty hung up, a TCP
    /// connection reset).
    Failed(io::Error),
}

impl StreamEnd {
    /// A sentence for the user, naming the endpoint.
    pub fn describe(&self, endpoint: &Endpoint) -> String {
        match self {
            Self::Eof => format!("{endpoint}: end of file"),
            Self::Closed => match endpoint {
                Endpoint::Tcp(_) => format!("{endpoint}: the device closed the connection"),
                _ => format!("{endpoint}: the device disappeared (the port hung up)"),
            },
            Self::Failed(e) => format!("{endpoint}: the device disappeared ({e})"),
        }
    }
}

impl Connection {
    /// True if commands can be sent (serial, TCP).
    pub fn writable(&self) -> bool {
        self.writer.is_some()
    }

    /// Split into the reader thread, which sends every chunk it reads and
    /// then one [`Incoming::End`] to `tx` (as `T::from`), and the writer
    /// (none for a file). The thread also ends if `tx`'s receiver is gone.
    pub fn start<T: From<Incoming> + Send + 'static>(
        self,
        tx: SyncSender<T>,
    ) -> (JoinHandle<()>, Option<Box<dyn Write + Send>>) {
        let mut reader = self.reader;
        let live = self.endpoint.is_live();
        let handle = std::thread::spawn(move || {
            let mut buf = vec![0u8; CHUNK];
            let end = loop {
                match reader.read(&mut buf) {
                    Ok(0) if live => break StreamEnd::Closed,
                    Ok(0) => break StreamEnd::Eof,
                    Ok(n) => {
                        let bytes = buf.get(..n).unwrap_or_default().to_vec();
                        if tx
                            .send(Incoming::Bytes(bytes, Instant::now()).into())
                            .is_err()
                        {
                            return;
                        }
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::TimedOut
                                | io::ErrorKind::WouldBlock
                                | io::ErrorKind::Interrupted
                        ) => {}
                    Err(e) => break StreamEnd::Failed(e),
                }
            };
            let _ = tx.send(Incoming::End(end).into());
        });
        (handle, self.writer)
    }
}
