//! The bus scheduler (sans-IO). INTERFACE STUB.
