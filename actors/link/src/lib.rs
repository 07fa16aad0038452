//! kestrel-link
