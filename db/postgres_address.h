// What a `--db` / `--to` / `--queue` names, read strictly: a PostgreSQL server (a libpq URI,
// `postgresql://…` or `postgres://…`, or a libpq key/value connection string such as
// `host=db.plant dbname=armsig`) or an SQLite file (anything else).
//
// - A text whose first word is `keyword=` is a key/value connection string, never a file
//   name: it is parsed by libpq or refused (exit 2). A file whose name begins with `word=`
//   is given as `./word=…`. A text that begins with another scheme (`mysql://`, `file:`,
//   `postgresql:` without `//`) is refused too.
// - Secrets never stand in an address: libpq marks its secret parameters (password,
//   sslpassword); a URI or string that sets one in any spelling libpq reads (`user:pw@`,
//   `password=`, a percent-encoded key such as `pass%77ord=`, a quoted key/value) is refused
//   before anything connects. Credentials come from where libpq looks for them (PGPASSWORD,
//   ~/.pgpass, a service file, a client certificate).
// - Every message names a server by RedactedAddress: the address with every secret removed.
#pragma once

#include <string>
#include <string_view>

namespace armsig::db {

// Whether `text` names a PostgreSQL server (a URI or a key/value string).
bool IsPostgresAddress(std::string_view text);
// The address without its secrets, for messages: postgresql://job@db.plant/armsig,
// host=db.plant dbname=armsig. Anything else (a file name) is returned as it is.
std::string RedactedAddress(std::string_view address);
// What messages call the store at `location`: RedactedAddress for a server, the file name
// otherwise.
std::string StoreName(std::string_view location);

// Throws InputError naming `option` for a server address that carries a secret or that
// libpq cannot parse, and for a text that looks like an address of another kind (another
// scheme); connects to nothing. Accepts every SQLite file name.
void CheckStoreAddress(std::string_view location, std::string_view option = "--db");

}  // namespace armsig::db
