// The ctest fixture of the tests' PostgreSQL server (support/postgres_server.h):
//   armsig_test_postgres start DIR   a server in DIR, left running
//   armsig_test_postgres stop DIR    stopped, DIR removed
// Every test process finds it through $ARMSIG_TEST_POSTGRES=DIR.
#include <iostream>
#include <string>

#include "support/postgres_server.h"

int main(int argc, char** argv) {
  const std::string verb = argc == 3 ? argv[1] : "";
  if (verb != "start" && verb != "stop") {
    std::cerr << "usage: armsig_test_postgres start|stop DIR\n";
    return 2;
  }
  try {
    if (verb == "start")
      armsig::testing::PostgresServer::StartDetached(argv[2]);
    else
      armsig::testing::PostgresServer::StopDetached(argv[2]);
  } catch (const std::exception& e) {
    // Loud: every test that needs the server is skipped by ctest as "not run" after this.
    std::cerr << "armsig_test_postgres " << verb << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}
