// Who may use the HTTP API (control/access.h): the Host, Origin, Content-Type and token checks as
// pure functions, the token file and the token itself.
#include "contract/access_token.h"
#include "control/access.h"

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace doppel::control {
namespace {

constexpr const char* kToken = "00112233445566778899aabbccddeeff";

RequestHeaders get(const std::string& path, const std::string& host = "127.0.0.1:7580") {
  RequestHeaders r;
  r.method = "GET";
  r.path = path;
  r.host = host;
  r.authorization = std::string("Bearer ") + kToken;
  return r;
}

RequestHeaders post(const std::string& path) {
  RequestHeaders r = get(path);
  r.method = "POST";
  r.content_type = "application/json";
  return r;
}

TEST(AccessToken, Has128RandomBitsAsHexAndDiffersEachTime) {
  std::set<std::string> seen;
  for (int i = 0; i < 100; ++i) {
    const std::string token = contract::new_access_token();
    EXPECT_EQ(token.size(), 32u);
    EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos) << token;
    seen.insert(token);
  }
  EXPECT_EQ(seen.size(), 100u);
}

TEST(AccessToken, ComparedWhole) {
  EXPECT_TRUE(contract::same_token(kToken, kToken));
  EXPECT_FALSE(contract::same_token(kToken, "00112233445566778899aabbccddeefe"));
  EXPECT_FALSE(contract::same_token(kToken, "00112233445566778899aabbccddeeff0"));  // longer
  EXPECT_FALSE(contract::same_token(kToken, "0011"));                               // a prefix
  EXPECT_FALSE(contract::same_token("", ""));                                       // no token is never a match
}

TEST(AccessPolicy, TheHostMustNameThisServer) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, kToken);
  for (const char* host : {"127.0.0.1:7580", "localhost:7580", "LOCALHOST:7580", "[::1]:7580"}) {
    EXPECT_EQ(check_access(policy, get("/api/state", host)).status, 200) << host;
  }
  // DNS rebinding: the attacker's name resolves to 127.0.0.1, the browser sends that name.
  for (const char* host : {"attacker.example:7580", "127.0.0.1:7581", "127.0.0.1", "", "127.0.0.1:7580.evil", "localhost"}) {
    const AccessVerdict verdict = check_access(policy, get("/api/state", host));
    EXPECT_EQ(verdict.status, 403) << host;
    EXPECT_NE(verdict.error.find("Host"), std::string::npos) << verdict.error;
  }
  EXPECT_EQ(check_access(policy, get("/index.html", "attacker.example:7580")).status, 403);  // files too
}

TEST(AccessPolicy, TheNamedAddressAndOnAWildcardAnyIpLiteral) {
  const AccessPolicy lan = access_policy("192.168.7.2", 7580, kToken);
  EXPECT_EQ(check_access(lan, get("/api/state", "192.168.7.2:7580")).status, 200);
  EXPECT_EQ(check_access(lan, get("/api/state", "192.168.7.3:7580")).status, 403);
  const AccessPolicy v6 = access_policy("fd00::2", 7580, kToken);
  EXPECT_EQ(check_access(v6, get("/api/state", "[fd00::2]:7580")).status, 200);
  const AccessPolicy any = access_policy("0.0.0.0", 7580, kToken);
  EXPECT_EQ(check_access(any, get("/api/state", "10.1.2.3:7580")).status, 200);
  EXPECT_EQ(check_access(any, get("/api/state", "[fe80::1]:7580")).status, 200);
  EXPECT_EQ(check_access(any, get("/api/state", "rebound.example:7580")).status, 403);
  EXPECT_EQ(check_access(any, get("/api/state", "10.1.2.3:80")).status, 403);
}

TEST(AccessPolicy, AnOriginMustBeTheViewersOwn) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, kToken);
  RequestHeaders r = post("/api/pause");
  r.origin = "http://127.0.0.1:7580";
  EXPECT_EQ(check_access(policy, r).status, 200);
  for (const char* origin : {"http://evil.example", "http://127.0.0.1:8000", "null", "https://127.0.0.1:7580", "file://"}) {
    r.origin = origin;
    EXPECT_EQ(check_access(policy, r).status, 403) << origin;
    RequestHeaders read = get("/api/state");
    read.origin = origin;
    EXPECT_EQ(check_access(policy, read).status, 403) << origin;  // a cross-origin read is refused too
  }
}

TEST(AccessPolicy, AChangeMustBeJson) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, kToken);
  RequestHeaders r = post("/api/pause");
  r.content_type = "application/json; charset=utf-8";
  EXPECT_EQ(check_access(policy, r).status, 200);
  // The content types a page may send cross-origin without a preflight, and none at all.
  for (const char* type : {"text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x", ""}) {
    for (const char* method : {"POST", "PUT", "DELETE"}) {
      r.method = method;
      r.content_type = type;
      const AccessVerdict verdict = check_access(policy, r);
      EXPECT_EQ(verdict.status, 403) << method << " " << type;
      EXPECT_NE(verdict.error.find("application/json"), std::string::npos) << verdict.error;
    }
  }
}

TEST(AccessPolicy, TheApiNeedsTheTokenTheFilesDoNot) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, kToken);
  RequestHeaders none = get("/api/state");
  none.authorization.clear();
  EXPECT_EQ(check_access(policy, none).status, 401);
  EXPECT_EQ(check_access(policy, get("/")).status, 200);
  RequestHeaders page = get("/viewer.js");
  page.authorization.clear();
  EXPECT_EQ(check_access(policy, page).status, 200);

  RequestHeaders wrong = get("/api/state");
  wrong.authorization = "Bearer 00112233445566778899aabbccddeefe";
  const AccessVerdict refused = check_access(policy, wrong);
  EXPECT_EQ(refused.status, 401);
  EXPECT_NE(refused.error.find("wrong access token"), std::string::npos) << refused.error;

  RequestHeaders header = none;
  header.doppel_token = kToken;
  EXPECT_EQ(check_access(policy, header).status, 200);
  RequestHeaders cookie = none;
  cookie.cookie = std::string("other=1; doppel_token_7580=") + kToken + "; x=y";
  EXPECT_EQ(check_access(policy, cookie).status, 200);
  cookie.cookie = std::string("doppel_token_7581=") + kToken;  // another port's cookie
  EXPECT_EQ(check_access(policy, cookie).status, 401);

  // The link doppel prints: let in, and the page gets its cookie.
  RequestHeaders link = get("/");
  link.authorization.clear();
  link.query_token = kToken;
  const AccessVerdict first = check_access(policy, link);
  EXPECT_EQ(first.status, 200);
  EXPECT_TRUE(first.set_cookie);
  link.query_token = "nope";
  EXPECT_FALSE(check_access(policy, link).set_cookie);
  EXPECT_EQ(token_cookie_name(7580), "doppel_token_7580");
}

TEST(AccessPolicy, NoTokenLetsInWhatPassesHostAndOrigin) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, "");
  RequestHeaders r = get("/api/state");
  r.authorization.clear();
  EXPECT_EQ(check_access(policy, r).status, 200);
  r.host = "attacker.example:7580";
  EXPECT_EQ(check_access(policy, r).status, 403);
}

TEST(AccessPolicy, GarbageHeadersAreRefusedNotACrash) {
  const AccessPolicy policy = access_policy("127.0.0.1", 7580, kToken);
  RequestHeaders r = post("/api/pause");
  for (const std::string& junk : {std::string(5000, ':'), std::string("\0\xff\x01", 3), std::string("[:]"), std::string("]:")}) {
    r.host = junk;
    EXPECT_EQ(check_access(policy, r).status, 403);
    r.host = "127.0.0.1:7580";
    r.origin = junk;
    EXPECT_EQ(check_access(policy, r).status, 403);
    r.origin.clear();
    r.authorization = junk;
    r.cookie = junk;
    EXPECT_EQ(check_access(policy, r).status, 401);
    r.authorization = std::string("Bearer ") + kToken;
    r.cookie.clear();
  }
}

TEST(TokenFile, PrivateToTheUserReadAsClientsReadItAndRemovedAtTheEnd) {
  char pattern[] = "/tmp/doppel-access-test-XXXXXX";
  const std::string dir = ::mkdtemp(pattern);
  const std::string path = contract::token_file_path(dir, 7580);
  EXPECT_EQ(path, dir + "/token-7580");
  ::unsetenv("DOPPEL_TOKEN");
  EXPECT_FALSE(contract::find_access_token(dir, 7580).has_value());
  std::filesystem::create_symlink("/tmp/elsewhere-" + std::to_string(::getpid()), path);  // replaced, not followed
  {
    const contract::TokenFile file(path, kToken);
    struct stat st{};
    ASSERT_EQ(::lstat(path.c_str(), &st), 0);
    EXPECT_TRUE(S_ISREG(st.st_mode));
    EXPECT_EQ(st.st_mode & 0777, 0600u);
    EXPECT_EQ(st.st_uid, ::geteuid());
    EXPECT_EQ(contract::find_access_token(dir, 7580), std::optional<std::string>(kToken));
    EXPECT_FALSE(contract::find_access_token(dir, 7581).has_value());
    ::setenv("DOPPEL_TOKEN", "from-the-environment", 1);
    EXPECT_EQ(contract::find_access_token(dir, 7580), std::optional<std::string>("from-the-environment"));
    ::unsetenv("DOPPEL_TOKEN");
  }
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(path)));
  EXPECT_FALSE(std::filesystem::exists("/tmp/elsewhere-" + std::to_string(::getpid())));
  // A file somebody put in its place after the start is not removed.
  {
    const contract::TokenFile file(path, kToken);
    std::filesystem::remove(path);
    std::ofstream(path) << "another\n";
  }
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::control
