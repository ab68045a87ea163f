//! SocketCAN kernel tests (being written).
