#include "app/command.h"

int main(int argc, char** argv) { return armsig::app::Main(argc, argv); }
