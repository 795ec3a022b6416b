// Robot Web Services replies and the HTTP authentication headers around them: every input
// through the XHTML and JSON readers and the typed decoders (controller state, mode,
// execution, identity, robot type and serial, jointtarget, symbol values), the RAPID
// literal readers, the challenge and credentials grammar, cookies, Base64 and forms. A
// reader may refuse only with rws::DecodeError or http::HeaderError; what decodes must
// write back to something that decodes again.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "robots/http_auth.h"
#include "robots/rws_codec.h"

namespace {

namespace rws = armsig::robots::rws;
namespace http = armsig::robots::http;

template <typename F>
void Refusable(F&& f) {
  try {
    f();
  } catch (const rws::DecodeError&) {
  } catch (const http::HeaderError&) {
  }
}

void Decoders(const rws::Document& d) {
  Refusable([&] { (void)rws::DecodeControllerState(d); });
  Refusable([&] { (void)rws::DecodeOperationMode(d); });
  Refusable([&] { (void)rws::DecodeExecutionState(d); });
  Refusable([&] { (void)rws::DecodeIdentity(d); });
  Refusable([&] { (void)rws::DecodeSystemInfo(d); });
  Refusable([&] { (void)rws::DecodeRobotTypes(d); });
  Refusable([&] { (void)rws::DecodeRobotSerial(d); });
  Refusable([&] { (void)rws::DecodeJointTargetDeg(d); });
  Refusable([&] {
    const std::string value = rws::DecodeSymbolValue(d);
    Refusable([&] { (void)rws::ParseRapidArray(value); });
    Refusable([&] { (void)rws::ParseRapidJointTarget(value); });
  });
  for (rws::Representation r :
       {rws::Representation::kXhtml, rws::Representation::kJson1, rws::Representation::kHalJson}) {
    // What was read can be written; what is written may be refused only in the same way.
    const std::string text = rws::Format(d, r, "fuzz", "http://h/");
    Refusable([&] { (void)rws::Parse(text, rws::MediaType(r)); });
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text = armsig::fuzz::Text(data, size);
  Refusable([&] { Decoders(rws::ParseXhtml(text)); });
  Refusable([&] { Decoders(rws::ParseJson(text)); });

  Refusable([&] { (void)rws::ParseRapidNum(text); });
  Refusable([&] {
    const rws::JointTarget t = rws::ParseRapidJointTarget(text);
    const rws::JointTarget back = rws::ParseRapidJointTarget(rws::FormatRapidJointTarget(t));
    for (size_t i = 0; i < 6; ++i) {
      // Nine significant digits: a float's value comes back; a double's within 1e-8.
      if (std::abs(back.robax_deg[i] - t.robax_deg[i]) > 1e-8 * (1 + std::abs(t.robax_deg[i]))) {
        std::abort();
      }
    }
  });
  Refusable([&] {
    const auto values = rws::ParseRapidArray(text);
    if (rws::ParseRapidArray(rws::FormatRapidArray(values)).size() != values.size()) std::abort();
  });

  Refusable([&] {
    for (const http::Challenge& c : http::ParseChallenges(text)) {
      Refusable([&] {
        const std::string answer = http::DigestAuthorization(c, "u", "p", "GET", "/", "c", 1);
        if (http::ParseCredentials(answer).scheme != "Digest") std::abort();
      });
    }
  });
  Refusable([&] { (void)http::ParseCredentials(text); });
  (void)http::ParseSetCookie(text);
  (void)http::ParseCookieHeader(text);
  (void)http::ParseBasicAuthorization(text);
  (void)http::CanonicalFingerprint(text);
  if (const auto decoded = http::Base64Decode(text)) {
    if (http::Base64Decode(http::Base64Encode(*decoded)) != decoded) std::abort();
  }
  Refusable([&] { (void)rws::ParseForm(text); });
  return 0;
}
