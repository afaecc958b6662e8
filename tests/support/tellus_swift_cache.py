"""An in-process stand-in for Swift's memcache middleware (s3-server.sh's proxy runs one process,
workers = 0): tempauth keeps its tokens and groups in `swift.cache`, and memcached would be one
more server to start for nothing. Loaded by paste.deploy (`paste.filter_factory`)."""
import threading
import time


class DictCache:
    def __init__(self):
        self._lock = threading.Lock()
        self._items = {}

    def _live(self, key):
        item = self._items.get(key)
        if item and item[1] and item[1] < time.time():
            del self._items[key]
            return None
        return item

    def get(self, key, raise_on_error=False):
        with self._lock:
            item = self._live(key)
            return item[0] if item else None

    def set(self, key, value, serialize=True, time=0, min_compress_len=0, raise_on_error=False):
        import time as _t
        with self._lock:
            self._items[key] = (value, _t.time() + time if time else 0)

    def incr(self, key, delta=1, time=0):
        with self._lock:
            item = self._live(key)
            value = (int(item[0]) if item else 0) + delta
            self._items[key] = (value, item[1] if item else 0)
            return value

    def decr(self, key, delta=1, time=0):
        return self.incr(key, -delta, time)

    def delete(self, key, server_key=None):
        with self._lock:
            self._items.pop(key, None)

    def get_multi(self, keys, server_key):
        return [self.get(k) for k in keys]

    def set_multi(self, mapping, server_key, serialize=True, time=0, min_compress_len=0):
        for k, v in mapping.items():
            self.set(k, v, time=time)


def filter_factory(global_conf, **local_conf):
    cache = DictCache()

    def make(app):
        def middleware(env, start_response):
            env["swift.cache"] = cache
            return app(env, start_response)
        return middleware
    return make
