#include "model_cache.hpp"

#include "godot/ref.hpp"

#include <atomic>
#include <map>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <thread>
#include <vector>

using namespace godot;

namespace ardy {

namespace {

// Reads a whole file through the engine, so paths inside an exported .pck work.
std::string read_engine_file(const std::string &path) {
	Ref<FileAccess> file = FileAccess::open(String(path), FileAccess::READ);
	if (file.is_null()) {
		throw Error("cannot open '" + path + "': " + error_string(FileAccess::get_open_error()).utf8());
	}
	const uint64_t length = file->get_length();
	const PackedByteArray bytes = file->get_buffer(static_cast<int64_t>(length));
	if (static_cast<uint64_t>(bytes.size()) != length || file->get_error() != OK) {
		throw Error("cannot read '" + path + "': " + error_string(file->get_error()).utf8());
	}
	return std::string(reinterpret_cast<const char *>(bytes.ptr()), static_cast<size_t>(bytes.size()));
}

struct LoadThread {
	std::thread thread;
	// Set by the thread as it ends; the thread holds the model only while it
	// loads, so a model nobody wants any more is freed at once.
	std::shared_ptr<std::atomic<bool>> finished;
};

struct Registry {
	std::mutex mutex;
	std::map<std::string, std::weak_ptr<SharedModel>> models;
	std::vector<LoadThread> loads;
	std::weak_ptr<OnnxEnvironment> environment;

	// Joins the loads that have ended (under mutex).
	void reap() {
		for (auto it = loads.begin(); it != loads.end();) {
			if (it->finished->load()) {
				it->thread.join();
				it = loads.erase(it);
			} else {
				++it;
			}
		}
	}
};

Registry &registry() {
	static Registry instance;
	return instance;
}

void load(const std::shared_ptr<SharedModel> &model, std::shared_ptr<OnnxEnvironment> environment) {
	try {
		PackageOptions options;
		options.environment = std::move(environment);
		const std::string folder = model->path().back() == '/' ? model->path() : model->path() + "/";
		const PackageFileReader read = [&folder](const std::string &file) { return read_engine_file(folder + file); };
		model->finish(std::make_shared<const ModelPackage>(ModelPackage::from_reader(read, model->path(), options)), "");
	} catch (const std::exception &failure) {
		model->finish(nullptr, failure.what());
	}
}

} // namespace

SharedModel::~SharedModel() {
	batcher_.reset();
	package_.reset();
#if defined(__GLIBC__)
	// A package's sessions free hundreds of blocks of every size; without a
	// trim the process keeps them (resident memory climbs over model swaps).
	malloc_trim(0);
#endif
}

bool SharedModel::is_done() const {
	std::lock_guard<std::mutex> lock(mutex_);
	return done_;
}

std::shared_ptr<const ModelPackage> SharedModel::package() const {
	std::lock_guard<std::mutex> lock(mutex_);
	return package_;
}

std::string SharedModel::error() const {
	std::lock_guard<std::mutex> lock(mutex_);
	return error_;
}

WindowGenerator SharedModel::batched_generator() const {
	std::lock_guard<std::mutex> lock(mutex_);
	return batcher_ ? batcher_->generator() : WindowGenerator();
}

WindowBatcherStats SharedModel::batcher_stats() const {
	std::lock_guard<std::mutex> lock(mutex_);
	return batcher_ ? batcher_->stats() : WindowBatcherStats();
}

void SharedModel::finish(std::shared_ptr<const ModelPackage> package, std::string error) {
	std::unique_ptr<WindowBatcher> batcher;
	if (package) {
		batcher = std::make_unique<WindowBatcher>();
	}
	std::lock_guard<std::mutex> lock(mutex_);
	package_ = std::move(package);
	batcher_ = std::move(batcher);
	error_ = std::move(error);
	done_ = true;
}

std::shared_ptr<SharedModel> acquire_model(const std::string &path) {
	Registry &reg = registry();
	std::lock_guard<std::mutex> lock(reg.mutex);
	reg.reap();
	if (auto existing = reg.models[path].lock()) {
		// A failed load is not shared: asking again retries (the files may be fixed now).
		if (!existing->is_done() || existing->package()) {
			return existing;
		}
	}
	auto model = std::make_shared<SharedModel>(path);
	reg.models[path] = model;
	std::shared_ptr<OnnxEnvironment> environment = reg.environment.lock();
	if (!environment) {
		environment = OnnxEnvironment::create();
		reg.environment = environment;
	}
	auto finished = std::make_shared<std::atomic<bool>>(false);
	std::thread thread([model, environment = std::move(environment), finished]() mutable {
		load(model, std::move(environment));
		model.reset();
		finished->store(true);
	});
	reg.loads.push_back({ std::move(thread), std::move(finished) });
	return model;
}

size_t live_model_count() {
	Registry &reg = registry();
	std::lock_guard<std::mutex> lock(reg.mutex);
	size_t count = 0;
	for (const auto &entry : reg.models) {
		if (auto model = entry.second.lock(); model && model->package()) {
			++count;
		}
	}
	return count;
}

void shut_down_model_loads() {
	Registry &reg = registry();
	std::vector<LoadThread> loads;
	{
		std::lock_guard<std::mutex> lock(reg.mutex);
		loads.swap(reg.loads);
		reg.models.clear();
	}
	for (LoadThread &load : loads) {
		load.thread.join();
	}
}

} // namespace ardy
