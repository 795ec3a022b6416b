#include "simulation/tls_certificate.h"

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio/ip/address.hpp>
// clang-format on
#include <openssl/pem.h>
#include <openssl/x509v3.h>

#include <random>
#include <stdexcept>

#include "robots/http_auth.h"

namespace armsig::simulation {

namespace {

void AddExtension(X509* x, int nid, const std::string& value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, x, x, nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value.c_str());
  if (!ext) throw std::runtime_error("cannot make the certificate extension " + value);
  X509_add_ext(x, ext, -1);
  X509_EXTENSION_free(ext);
}

}  // namespace

Certificate MakeCertificate(const std::string& host, const std::string& common_name) {
  Certificate c;
  c.key.reset(EVP_EC_gen("P-256"));
  c.x509.reset(X509_new());
  if (!c.key || !c.x509) throw std::runtime_error("OpenSSL cannot make a key or a certificate");
  X509* x = c.x509.get();
  X509_set_version(x, 2);
  std::random_device rd;
  ASN1_INTEGER_set(X509_get_serialNumber(x), static_cast<long>(rd() & 0x7fffffff));
  X509_gmtime_adj(X509_getm_notBefore(x), -3600);
  X509_gmtime_adj(X509_getm_notAfter(x), 365L * 24 * 3600);
  X509_set_pubkey(x, c.key.get());
  X509_NAME* name = X509_get_subject_name(x);
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC,
                             reinterpret_cast<const unsigned char*>(common_name.c_str()), -1, -1,
                             0);
  X509_set_issuer_name(x, name);
  boost::system::error_code ec;
  boost::asio::ip::make_address(host, ec);
  std::string san = "DNS:localhost,IP:127.0.0.1";
  if (host != "127.0.0.1" && host != "localhost") san += (ec ? ",DNS:" : ",IP:") + host;
  AddExtension(x, NID_subject_alt_name, san);
  AddExtension(x, NID_basic_constraints, "critical,CA:TRUE");
  AddExtension(x, NID_key_usage, "critical,digitalSignature,keyCertSign");
  if (X509_sign(x, c.key.get(), EVP_sha256()) <= 0) {
    throw std::runtime_error("OpenSSL cannot sign the certificate");
  }
  std::unique_ptr<BIO, decltype(&BIO_free)> bio(BIO_new(BIO_s_mem()), BIO_free);
  PEM_write_bio_X509(bio.get(), x);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  c.pem.assign(data, static_cast<size_t>(n));
  const int der_size = i2d_X509(x, nullptr);
  std::string der(static_cast<size_t>(der_size), '\0');
  auto* p = reinterpret_cast<unsigned char*>(der.data());
  i2d_X509(x, &p);
  c.fingerprint = robots::http::Sha256Fingerprint(der);
  return c;
}

}  // namespace armsig::simulation
