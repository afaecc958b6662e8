// What a renderer shows: the window's image (the scene, or the projector's warped and blended
// image: ProjectorWarp.hpp), presented at once or on request (RendererOptions::presentOnRequest,
// the cluster's go), and read back.

#include "RendererImpl.hpp"

namespace tellus::planet {

void Renderer::Impl::present() {
  if (!opt.visibleWindow) return;
  context->makeCurrent();
  if (projector) {
    presenter.present(
        context->window(), projector->framebuffer(), projector->width(), projector->height());
    return;
  }
  const SceneFramebuffer& fb = scene->framebuffer();
  presenter.present(context->window(), fb.id(), fb.width(), fb.height());
}

void Renderer::present() {
  impl_->present();
}

std::vector<std::uint8_t> Renderer::readPresented() const {
  impl_->context->makeCurrent();
  if (impl_->projector) return impl_->projector->readPixels();
  return impl_->scene->framebuffer().readPixels();
}

} // namespace tellus::planet
