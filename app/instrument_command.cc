// armsig instrument probe|read --port PATH|--tcp HOST:PORT --protocol geocom|gsi|val|as|emscon
// armsig instrument probe|read --tcp HOST[:PORT] --protocol ur|kuka|abb
// armsig instrument simulate --protocol P [--link PATH | --tcp HOST:PORT] [--seconds N] [--fault F]
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/text.h"
#include "instruments/device.h"
#include "workflows/instrument.h"
#include "demo/virtual_instrument.h"

namespace armsig::app {

void SetupInstrumentCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto* sub =
      parent.add_subcommand("instrument", "Talk to one instrument (probe | read), or simulate one");
  sub->require_subcommand(1);
  for (const char* action : {"probe", "read"}) {
    auto o = std::make_shared<workflows::InstrumentRequest>();
    o->action = action;
    auto* a = sub->add_subcommand(
        action, std::string(action) == "probe"
                    ? "Identify the instrument (name, serial, firmware) or the robot controller "
                      "(model, serial, software; UR: its kinematics checksum)"
                    : "Take one measurement (a controller: its joints)");
    a->add_option("--port", o->port, "Serial port (or pty) path")->type_name("PATH");
    a->add_option("--tcp", o->tcp, "HOST:PORT instead of a serial port")->type_name("ADDRESS");
    ChoiceOption(a->add_option("--protocol", o->protocol,
                               "geocom | gsi | emscon (instruments), val | as (controllers on a "
                               "serial port), ur | kuka | abb (controllers on the network: --tcp "
                               "HOST[:PORT])"),
                 {"geocom", "gsi", "val", "as", "emscon", "ur", "kuka", "abb"})
        ->capture_default_str();
    a->add_option("--controller-port", o->controller_ports,
                  "A network controller's other port, KEY=PORT with its lab-file key (ur: "
                  "rtde_port, primary_port, secondary_port; --tcp gives the dashboard's)")
        ->type_name("KEY=PORT");
    a->add_option("--controller-setting", o->controller_settings,
                  "A network controller's lab-file setting, KEY=VALUE (abb: rws=1 for an IRC5, "
                  "certificate_sha256=… to pin an OmniCore's certificate); credentials come "
                  "from ARMSIG_CONTROLLER_USER and ARMSIG_CONTROLLER_PASSWORD")
        ->type_name("KEY=VALUE");
    NumberOption(a->add_option("--baud", o->baud, "Baud rate"), 50, 4000000)->capture_default_str();
    NumberOption(a->add_option("--timeout-ms", o->timeout_ms,
                               "Deadline of the whole exchange, from the command to the parsed "
                               "reply (retries included)"),
                 1, 24 * 3600 * 1000)
        ->capture_default_str();
    a->add_flag("--crc", o->crc, "GeoCOM: CRC-16 on every frame");
    a->add_flag("--distance", o->distance, "read: measure the distance too");
    a->add_flag("--json", o->json, "Machine-readable output");
    OnlyReads(a);
    a->callback([&run, o] {
      run = [o] {
        try {
          std::cout << workflows::QueryInstrument(*o);
          return kOk;
        } catch (const instruments::InstrumentError& e) {
          // An instrument's return code is named when it has one (a GeoCOM or emScon code);
          // a controller's fault says what it is in words alone.
          if (e.code() != 0) {
            spdlog::error("instrument: {} (code {})", e.what(), e.code());
          } else {
            spdlog::error("instrument: {}", e.what());
          }
          return kFailure;
        }
      };
    });
  }
  auto o = std::make_shared<demo::SimulateRequest>();
  auto* s = sub->add_subcommand(
      "simulate", "Start a virtual instrument on a pseudo-terminal for manual trials");
  s->add_option("--protocol", o->protocol, "geocom | gsi | val | as | emscon")
      ->capture_default_str();
  s->add_option("--tcp", o->tcp, "emscon: HOST:PORT to listen on (e.g. 127.0.0.1:7000)")
      ->type_name("ADDRESS");
  s->add_option("--link", o->link, "Path of the port to create (a symlink to the pty)")
      ->type_name("PATH")
      ->capture_default_str();
  NumberOption(s->add_option("--seconds", o->seconds, "Stop after this many seconds (0: Ctrl-C)"),
               0, 1e6);
  s->add_option("--fault", o->fault,
                "Misbehave on every request: flood-bytes, endless-line, flood-lines, silence, "
                "partial, wrong-trid, bad-crc, no-crc, busy, error, other-reply, out-of-range, "
                "wrong-unit, vanish, noise; emscon also wrong-command-id, beam-break, "
                "reflector-not-found, status-between, status-inside");
  OnlyReads(s);
  s->callback([&run, o] {
    run = [o] {
      demo::SimulateRequest request = *o;
      request.stop = &StopRequested();
      const int64_t served = demo::RunVirtualInstrument(request, [&](const std::string& path) {
        std::cout << fmt::format("virtual {} instrument on {}{}", request.protocol, Printable(path),
                                 request.seconds > 0 ? fmt::format(" for {} s", request.seconds)
                                                     : std::string(" until Ctrl-C"))
                  << std::endl;
      });
      std::cout << served << " requests served\n";
      return StopRequested() ? kStopped : kOk;  // Ctrl-C: 130, as every command it stops
    };
  });
}

}  // namespace armsig::app
