// HTTP authentication pieces against the RFCs' own worked examples (RFC 2617 section 3.5 and
// RFC 7616 section 3.9.1 for Digest, RFC 7617 section 2 for Basic) and FIPS 180-2's SHA-256
// test vector: numbers that come from outside armsig.
#include "robots/http_auth.h"

#include <gtest/gtest.h>

namespace armsig::robots::http {
namespace {

TEST(HttpAuth, DigestResponseIsRfc2617sWorkedExample) {
  // RFC 2617 section 3.5: Mufasa / "Circle Of Life" on testrealm@host.com.
  EXPECT_EQ(DigestResponse("Mufasa", "testrealm@host.com", "Circle Of Life", "GET",
                           "/dir/index.html", "dcd98b7102dd2f0e8b11d0f600bfb0c093", "00000001",
                           "0a4f113b"),
            "6629fae49393a05397450978507c4ef1");
}

TEST(HttpAuth, DigestResponseIsRfc7616sMd5Example) {
  // RFC 7616 section 3.9.1 (MD5).
  EXPECT_EQ(DigestResponse("Mufasa", "http-auth@example.org", "Circle of Life", "GET",
                           "/dir/index.html", "7ypf/xlj9XXwfDPEoM4URrv/xwf94BcCAzFZH4GiTo0v",
                           "00000001", "f2/wE4q74E6zIJEtWaHKaf5wv/H5QzzpXusqGemxURZJ"),
            "8ca523f5e9506fed4657c9700eebdbec");
}

TEST(HttpAuth, DigestAuthorizationAnswersTheChallengeItWasGiven) {
  const auto challenges = ParseChallenges(
      "Digest realm=\"testrealm@host.com\", qop=\"auth,auth-int\", "
      "nonce=\"dcd98b7102dd2f0e8b11d0f600bfb0c093\", opaque=\"5ccc069c403ebaf9f0171e9517f40e41\"");
  ASSERT_EQ(challenges.size(), 1u);
  const std::string header = DigestAuthorization(challenges[0], "Mufasa", "Circle Of Life", "GET",
                                                 "/dir/index.html", "0a4f113b", 1);
  const Challenge c = ParseCredentials(header);
  EXPECT_EQ(c.scheme, "Digest");
  EXPECT_EQ(*c.Param("response"), "6629fae49393a05397450978507c4ef1");
  EXPECT_EQ(*c.Param("nc"), "00000001");
  EXPECT_EQ(*c.Param("qop"), "auth");
  EXPECT_EQ(*c.Param("opaque"), "5ccc069c403ebaf9f0171e9517f40e41");
  EXPECT_EQ(*c.Param("uri"), "/dir/index.html");
  EXPECT_EQ(header.find("Circle Of Life"), std::string::npos);  // never the password itself
}

TEST(HttpAuth, ChallengesAreSplitAndRefusedWhereMalformed) {
  const auto c = ParseChallenges(
      "Digest realm=\"a \\\"quoted\\\" realm\", nonce=abc, qop=\"auth\", Basic realm=\"b\"");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].scheme, "Digest");
  EXPECT_EQ(*c[0].Param("realm"), "a \"quoted\" realm");
  EXPECT_EQ(*c[0].Param("nonce"), "abc");
  EXPECT_EQ(c[1].scheme, "Basic");
  EXPECT_EQ(*c[1].Param("realm"), "b");
  for (const char* bad : {"", "   ", "Digest realm=\"unterminated", "Digest =x", "Digest realm=a b"}) {
    EXPECT_THROW(ParseChallenges(bad), HeaderError) << bad;
  }
  // A challenge asking for what is not implemented cannot be answered.
  const auto sha = ParseChallenges("Digest realm=\"r\", nonce=\"n\", algorithm=SHA-256");
  EXPECT_THROW(DigestAuthorization(sha[0], "u", "p", "GET", "/", "c", 1), HeaderError);
  const auto int_only = ParseChallenges("Digest realm=\"r\", nonce=\"n\", qop=\"auth-int\"");
  EXPECT_THROW(DigestAuthorization(int_only[0], "u", "p", "GET", "/", "c", 1), HeaderError);
}

TEST(HttpAuth, BasicIsRfc7617sExampleAndDecodesBack) {
  EXPECT_EQ(BasicAuthorization("Aladdin", "open sesame"), "Basic QWxhZGRpbjpvcGVuIHNlc2FtZQ==");
  const auto back = ParseBasicAuthorization("Basic QWxhZGRpbjpvcGVuIHNlc2FtZQ==");
  ASSERT_TRUE(back);
  EXPECT_EQ(back->first, "Aladdin");
  EXPECT_EQ(back->second, "open sesame");
  EXPECT_FALSE(ParseBasicAuthorization("Digest x=y"));
  EXPECT_FALSE(ParseBasicAuthorization("Basic bm9jb2xvbg=="));  // "nocolon"
}

TEST(HttpAuth, Base64IsStrict) {
  EXPECT_EQ(Base64Encode(""), "");
  EXPECT_EQ(Base64Encode("f"), "Zg==");
  EXPECT_EQ(Base64Encode("fo"), "Zm8=");
  EXPECT_EQ(Base64Encode("foobar"), "Zm9vYmFy");  // RFC 4648 section 10
  EXPECT_EQ(*Base64Decode("Zm8="), "fo");
  EXPECT_EQ(*Base64Decode("Zm9vYmFy"), "foobar");
  for (const char* bad : {"Zm8", "Zm=8", "Z===", "Zm8=Zm8=", "Zm\n8=", "Zm8*"}) {
    EXPECT_FALSE(Base64Decode(bad)) << bad;
  }
}

TEST(HttpAuth, CookiesKeepNameAndValueOnly) {
  const auto c = ParseSetCookie("-http-session-=12::http.session::ab12; path=/; httponly");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->name, "-http-session-");
  EXPECT_EQ(c->value, "12::http.session::ab12");
  EXPECT_FALSE(ParseSetCookie("no pair; path=/"));
  EXPECT_FALSE(ParseSetCookie("=value"));
  const auto all = ParseCookieHeader("-http-session-=1::x; ABBCX=1");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[1].name, "ABBCX");
  EXPECT_EQ(all[1].value, "1");
}

TEST(HttpAuth, FingerprintIsSha256InColonHex) {
  // FIPS 180-2, appendix B.1: SHA-256("abc").
  EXPECT_EQ(Sha256Fingerprint("abc"),
            "BA:78:16:BF:8F:01:CF:EA:41:41:40:DE:5D:AE:22:23:B0:03:61:A3:96:17:7A:9C:B4:10:FF:61:"
            "F2:00:15:AD");
  EXPECT_EQ(*CanonicalFingerprint(
                " ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad "),
            Sha256Fingerprint("abc"));
  EXPECT_EQ(*CanonicalFingerprint(Sha256Fingerprint("abc")), Sha256Fingerprint("abc"));
  EXPECT_FALSE(CanonicalFingerprint("BA:78"));
  EXPECT_FALSE(CanonicalFingerprint(std::string(64, 'g')));
  EXPECT_EQ(Md5Hex(""), "d41d8cd98f00b204e9800998ecf8427e");  // RFC 1321 A.5
}

}  // namespace
}  // namespace armsig::robots::http
