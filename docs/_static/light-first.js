// The charts are drawn on a white page (their backdrop): show the light theme unless the
// reader has picked one with the theme button.
if (!localStorage.getItem("theme")) {
  localStorage.setItem("theme", "light");
}
