# Varnish 7 in front of `tellus serve` (docs/design/cdn.md): caches what tellus says it may keep
# (Cache-Control s-maxage, stale-while-revalidate as grace, stale-if-error as keep), never an
# error (tellus sends no-store on every one), and forgets by surrogate key: `PURGE /` with an
# `xkey-purge: layer:sat layer:sat@2024-01-01 ...` header (what `tellus cache prune` and
# `tellus seed --refresh` send to each `server.cdn.purge` URL) from an allowed address removes
# every object whose `xkey` header named one of those keys (vmod_xkey, Debian's
# varnish-modules). Run: varnishd -a :6081 -f /path/to/varnish.vcl (tests/support/varnish.sh
# starts one on loopback with the backend's port written in).
vcl 4.1;

import std;
import xkey;

backend tellus {
  .host = "127.0.0.1";
  .port = "8080";
}

# Who may purge: tellus's hosts. Loopback only here; add the machines that run `tellus`.
acl purgers {
  "127.0.0.1";
  "::1";
}

sub vcl_recv {
  if (req.method == "PURGE") {
    if (client.ip !~ purgers) {
      return (synth(403, "purge refused"));
    }
    if (!req.http.xkey-purge) {
      return (synth(400, "PURGE needs an xkey-purge header"));
    }
    # xkey.softpurge would keep the objects for grace; a purge after a prune or refresh wants
    # them gone.
    set req.http.n-gone = xkey.purge(req.http.xkey-purge);
    return (synth(200, "purged " + req.http.n-gone + " objects"));
  }
  if (req.method != "GET" && req.method != "HEAD") {
    return (pass);
  }
  # tellus's answers do not depend on cookies or credentials.
  unset req.http.Cookie;
  return (hash);
}

sub vcl_backend_response {
  # stale-if-error: keep the object this long past its grace, so that a failed background fetch
  # (below) still has it to serve. Varnish reads s-maxage (ttl) and stale-while-revalidate
  # (grace) itself.
  if (beresp.http.Cache-Control ~ "stale-if-error=[0-9]+") {
    set beresp.keep = std.duration(
        regsub(beresp.http.Cache-Control, "^.*stale-if-error=([0-9]+).*$", "\1s"), 0s);
  }
  # A background fetch (an object in grace) that tellus fails: keep serving the old object.
  if (beresp.status >= 500 && bereq.is_bgfetch) {
    return (abandon);
  }
}

sub vcl_deliver {
  # The surrogate keys are for this cache, not for clients.
  unset resp.http.xkey;
}
