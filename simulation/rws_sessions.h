// The virtual ABB controller's users and sessions (simulation/rws_simulator.h), as ABB's
// "Application Manual - Robot Web Services" (3HAC050973-001 Revision M) and the OmniCore App
// SDK 1.5.0 describe them: RWS 1.0 answers a request without a session with a Digest challenge
// (MD5, qop=auth, the realm "validusers@robapi.abb": this simulator's choice, ABB does not
// state it), RWS 2.0 with a Basic one (inside TLS); credentials that answer it open a session,
// the cookie pair -http-session- and ABBCX set on that reply, which later requests carry.
#pragma once

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/beast/http.hpp>
// clang-format on
#include <deque>
#include <map>
#include <optional>
#include <random>
#include <string>

#include "robots/rws_codec.h"

namespace armsig::simulation {

class RwsSessions {
 public:
  RwsSessions(robots::rws::Version version, std::string user, std::string password);

  using Request = boost::beast::http::request<boost::beast::http::string_body>;
  using Response = boost::beast::http::response<boost::beast::http::string_body>;
  // The session of `request`: its cookies' one, or a new one when its credentials answer a
  // challenge (its cookies set on `response`); nullopt when refused (a challenge set on
  // `response`, to be answered with 401).
  std::optional<std::string> Authenticate(const Request& request, Response& response);
  void Logout(const std::string& session);
  int logins() const { return logins_; }  // sessions opened
  int refused_logins() const { return refused_logins_; }

 private:
  std::optional<std::string> SessionOf(const Request& request) const;
  bool CredentialsValid(const Request& request) const;
  std::string Challenge();

  robots::rws::Version version_;
  std::string user_, password_;
  std::mt19937_64 rng_{std::random_device{}()};
  std::map<std::string, std::string> sessions_;  // -http-session- → ABBCX
  int next_session_ = 0, logins_ = 0, refused_logins_ = 0;
  std::deque<std::string> nonces_;  // of the last challenges
  std::string opaque_ = "799d5e6b1c2c4d7e";
};

}  // namespace armsig::simulation
