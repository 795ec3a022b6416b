// A self-signed TLS certificate made at start, as a controller makes its own (the virtual
// OmniCore, simulation/rws_simulator.h): an EC P-256 key, SHA-256, valid a year, CA:TRUE so
// that a test can trust it as its own CA; its PEM and SHA-256 fingerprint (OpenSSL 3).
#pragma once

#include <openssl/evp.h>
#include <openssl/x509.h>

#include <memory>
#include <string>

namespace armsig::simulation {

struct Certificate {
  std::unique_ptr<X509, decltype(&X509_free)> x509{nullptr, X509_free};
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key{nullptr, EVP_PKEY_free};
  std::string pem, fingerprint;
};

// For `host` (its name or address among the subject's alternative names, with localhost and
// 127.0.0.1); std::runtime_error when OpenSSL cannot make it.
Certificate MakeCertificate(const std::string& host, const std::string& common_name);

}  // namespace armsig::simulation
