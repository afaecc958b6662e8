#include "FakeTileSource.hpp"

#include <algorithm>
#include <utility>

namespace tellus::test {

FakeTileSource::FakeTileSource(Layer forEveryName) : forEveryName_(std::move(forEveryName)) {}

FakeTileSource::~FakeTileSource() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  workCv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

// ---- configuration

void FakeTileSource::addLayer(Layer layer) {
  std::lock_guard lock(mutex_);
  std::string name = layer.name;
  layers_.insert_or_assign(std::move(name), std::move(layer));
}

void FakeTileSource::setFallbackAnswer(Answer answer) {
  std::lock_guard lock(mutex_);
  fallback_ = std::move(answer);
}

void FakeTileSource::setDelivery(Delivery delivery) {
  std::lock_guard lock(mutex_);
  delivery_ = delivery;
  if (delivery == Delivery::Worker && !worker_.joinable())
    worker_ = std::thread([this] { workLoop(); });
}

void FakeTileSource::holdIf(std::function<bool(const TileAddress&)> held) {
  std::lock_guard lock(mutex_);
  holdIf_ = std::move(held);
}

void FakeTileSource::failRequest(TileRequestId n, std::string message) {
  std::lock_guard lock(mutex_);
  failing_[n] = std::move(message);
}

// ---- answers

TileResult
FakeTileSource::result(TileStatus status, std::vector<std::byte> bytes, std::string contentType) {
  TileResult r;
  r.status = status;
  r.bytes = std::move(bytes);
  r.contentType = std::move(contentType);
  return r;
}

FakeTileSource::Answer FakeTileSource::absent() {
  return [](const TileAddress&) { return result(TileStatus::Absent); };
}

FakeTileSource::Answer FakeTileSource::failed(std::string message) {
  return [message](const TileAddress&) {
    TileResult r = result(TileStatus::Failed);
    r.message = message;
    return r;
  };
}

FakeTileSource::Answer FakeTileSource::bytes(std::vector<std::byte> bytes,
                                             std::string contentType) {
  return [bytes = std::move(bytes), contentType = std::move(contentType)](const TileAddress&) {
    return result(TileStatus::Ok, bytes, contentType);
  };
}

TileResult FakeTileSource::compute(const TileAddress& address, TileRequestId id) {
  Answer answer;
  {
    std::lock_guard lock(mutex_);
    if (const auto f = failing_.find(id); f != failing_.end()) {
      TileResult r = result(TileStatus::Failed);
      r.message = f->second;
      return r;
    }
    if (const auto l = layers_.find(address.layer); l != layers_.end())
      answer = l->second.answer;
    else if (forEveryName_)
      answer = forEveryName_->answer;
    if (!answer) answer = fallback_;
  }
  if (!answer) return result(TileStatus::Absent);
  std::lock_guard lock(answerMutex_);
  return answer(address);
}

FakeTileSource::Callback FakeTileSource::take(TileRequestId id) {
  if (id == 0 || id > entries_.size()) return {};
  Entry& e = entries_[id - 1];
  if (!e.request.open) return {};
  e.request.open = false;
  return std::move(e.done);
}

bool FakeTileSource::answer(TileRequestId id) {
  TileAddress address;
  Callback done;
  {
    std::lock_guard lock(mutex_);
    done = take(id);
    if (!done) return false;
    address = entries_[id - 1].request.address;
  }
  done(compute(address, id));
  return true;
}

bool FakeTileSource::answer(TileRequestId id, TileResult r) {
  Callback done;
  {
    std::lock_guard lock(mutex_);
    done = take(id);
  }
  if (!done) return false;
  done(std::move(r));
  return true;
}

bool FakeTileSource::answer(const TileKey& key, TileResult r) {
  TileRequestId id = 0;
  {
    std::lock_guard lock(mutex_);
    const auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) {
      return e.request.open && e.request.address.key == key;
    });
    if (it == entries_.end()) return false;
    id = it->request.id;
  }
  return answer(id, std::move(r));
}

std::size_t FakeTileSource::release(std::size_t n) {
  std::vector<TileRequestId> ids;
  {
    std::lock_guard lock(mutex_);
    for (const Entry& e : entries_)
      if (ids.size() < n && e.request.open && e.held) ids.push_back(e.request.id);
  }
  std::size_t answered = 0;
  for (const TileRequestId id : ids)
    if (answer(id)) ++answered;
  return answered;
}

// ---- what was asked

std::vector<FakeTileSource::Request> FakeTileSource::requests() const {
  std::lock_guard lock(mutex_);
  std::vector<Request> out;
  out.reserve(entries_.size() - firstRecorded_);
  for (std::size_t i = firstRecorded_; i < entries_.size(); ++i)
    out.push_back(entries_[i].request);
  return out;
}

std::vector<FakeTileSource::Request> FakeTileSource::openRequests() const {
  std::lock_guard lock(mutex_);
  std::vector<Request> out;
  for (const Entry& e : entries_)
    if (e.request.open) out.push_back(e.request);
  return out;
}

std::size_t FakeTileSource::requestCount() const {
  std::lock_guard lock(mutex_);
  return entries_.size() - firstRecorded_;
}

std::size_t FakeTileSource::openCount() const {
  std::lock_guard lock(mutex_);
  return static_cast<std::size_t>(std::count_if(
      entries_.begin(), entries_.end(), [](const Entry& e) { return e.request.open; }));
}

std::size_t FakeTileSource::requestsFor(std::string_view layer, std::string_view time) const {
  std::lock_guard lock(mutex_);
  std::size_t n = 0;
  for (std::size_t i = firstRecorded_; i < entries_.size(); ++i) {
    const TileAddress& a = entries_[i].request.address;
    if (a.layer == layer && a.time == time) ++n;
  }
  return n;
}

int FakeTileSource::deepestLevel(std::string_view layer) const {
  std::lock_guard lock(mutex_);
  int deepest = -1;
  for (std::size_t i = firstRecorded_; i < entries_.size(); ++i) {
    const TileAddress& a = entries_[i].request.address;
    if (a.layer == layer) deepest = std::max(deepest, a.key.level);
  }
  return deepest;
}

std::vector<TileRequestId> FakeTileSource::cancelled() const {
  std::lock_guard lock(mutex_);
  return cancelled_;
}

std::size_t FakeTileSource::reprioritizations() const {
  std::lock_guard lock(mutex_);
  return reprioritizations_;
}

void FakeTileSource::forgetRequests() {
  std::lock_guard lock(mutex_);
  firstRecorded_ = entries_.size();
}

// ---- ITileSource

std::optional<DatasetSpec> FakeTileSource::describe(std::string_view layer,
                                                    std::string_view time) const {
  std::lock_guard lock(mutex_);
  const Layer* l = nullptr;
  if (const auto it = layers_.find(layer); it != layers_.end())
    l = &it->second;
  else if (forEveryName_)
    l = &*forEveryName_;
  if (!l) return std::nullopt;
  DatasetSpec d;
  d.name = l->name;
  d.grid = l->grid;
  d.mimeType = l->mimeType;
  d.time = std::string(time);
  return d;
}

TileRequestId FakeTileSource::request(const TileAddress& address, double priority, Callback done) {
  TileRequestId id = 0;
  {
    std::lock_guard lock(mutex_);
    id = entries_.size() + 1;
    Entry e{Request{id, address, priority, true}, std::move(done), false};
    e.held = delivery_ == Delivery::Held || (holdIf_ && holdIf_(address));
    entries_.push_back(std::move(e));
    if (entries_.back().held) return id;
    if (delivery_ == Delivery::Worker) {
      workQueue_.push_back(id);
      workCv_.notify_one();
      return id;
    }
  }
  answer(id);
  return id;
}

void FakeTileSource::reprioritize(TileRequestId, double) {
  std::lock_guard lock(mutex_);
  ++reprioritizations_;
}

bool FakeTileSource::cancel(TileRequestId id) {
  Callback dropped; // destroyed outside the lock
  std::lock_guard lock(mutex_);
  dropped = take(id);
  if (!dropped) return false;
  cancelled_.push_back(id);
  return true;
}

void FakeTileSource::workLoop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    workCv_.wait(lock, [&] { return stopping_ || !workQueue_.empty(); });
    if (stopping_) return;
    const TileRequestId id = workQueue_.front();
    workQueue_.pop_front();
    Callback done = take(id);
    if (!done) continue; // cancelled
    const TileAddress address = entries_[id - 1].request.address;
    lock.unlock();
    done(compute(address, id));
    lock.lock();
  }
}

} // namespace tellus::test
