//! Shared glue of the subcommands: loading sites and logs from files.
